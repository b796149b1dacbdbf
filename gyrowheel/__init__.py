"""gyrowheel: a rolling wheel derived in CasADi and shipped as FMI 2.0 FMUs (docs/architecture.md)."""

__version__ = "0.1.0"
