"""gyrowheel's physics: the rolling wheel written symbolically in CasADi."""
from gyrowheel.model.build import build_model, FORMULATIONS
from gyrowheel.model.spec import ModelSpec

__all__ = ["build_model", "FORMULATIONS", "ModelSpec"]
