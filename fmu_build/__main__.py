import sys

from fmu_build.cli import main

sys.exit(main())
