"""The C runtime of every FMU (the `.c` and `.h` files beside this one), installed as package data.

Not Python code: this file only makes the folder the package `gyrowheel.c_src`, so that
`importlib.resources.files("gyrowheel.c_src")` finds the runtime in a wheel, an editable install
and a checkout alike (gyrowheel.fmu_build.runtime).
"""
