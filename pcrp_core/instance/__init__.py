"""Known objects seen by a depth camera: a gallery of meshes, one-sided views in metres.

When a model is built from meshes, what a camera can see of each object is worked out once
(templates.py): views rendered from all around, their silhouettes (signatures.py) and which
surface points each direction sees. A cloud from the camera is then matched by view: the
views whose silhouettes it resembles give poses to try (hypotheses.py), ICP refines the best
of them, and each refined pose is judged by how well the posed mesh explains the cloud and
the cloud covers what the mesh would show (verification.py). matcher.py wires the steps.
"""
