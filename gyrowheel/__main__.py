"""`python -m gyrowheel`: the gyrowheel command."""
import sys

from gyrowheel.cli import main

sys.exit(main())
