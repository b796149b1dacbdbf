"""gyrowheel's toolchain: CasADi code generation, modelDescription.xml, compiling, packaging, CLI."""
from gyrowheel.fmu_build.builder import BuildResult, build_fmu
from gyrowheel.fmu_build.scene import Scene, SceneError, load_scene, parse_scene

__all__ = ["BuildResult", "Scene", "SceneError", "build_fmu", "load_scene", "parse_scene"]
