"""How good pcrp is on the user's own meshes, as a robot's depth camera would see them.

`scenes` renders seeded, perfectly segmented depth-camera views of known meshes (free in space,
standing on a table, with or without an occluder); `metrics` holds the pose-error measures of the
YCB-Video and BOP benchmarks (ADD, ADD-S, its AUC); `run` answers every view with a model and
summarises the answers. `pcrp eval` is the command over these. Nothing here is imported by the
rest of the package, so the node does not pay for it.
"""
