"""momo: motion estimation from feature matches on motion manifolds, from Python.

numpy in, numpy out::

    import momo
    rig = momo.Rig.from_file("seq/rig.json")
    vo = momo.Odometry(rig, momo.Config.default())
    motion, diag = vo.process([matches_cam0], arc_length=0.8)  # (N, 4) arrays: u0, v0, u1, v1

See docs/PYTHON.md in the repository for the guide.
"""

from ._momo import (
    Config,
    ConfigError,
    Diagnostics,
    EstimationError,
    InputError,
    MatchError,
    MomoError,
    Odometry,
    Rig,
    RigError,
    Sequence,
    SimulationError,
    __version__,
    estimate,
    evaluate,
    read_poses,
    run,
    scenarios,
    simulate,
)
from ._momo import native_process_loop as _native_process_loop

__all__ = [
    "Config",
    "ConfigError",
    "Diagnostics",
    "EstimationError",
    "InputError",
    "MatchError",
    "MomoError",
    "Odometry",
    "Rig",
    "RigError",
    "Sequence",
    "SimulationError",
    "__version__",
    "estimate",
    "evaluate",
    "read_poses",
    "run",
    "scenarios",
    "simulate",
]
