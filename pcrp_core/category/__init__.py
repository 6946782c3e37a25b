"""The category-level path: answering a cloud by retrieval and registration against a gallery of
pre-aligned point clouds (PCRP, with this package's extensions).

answer.py      the cloud described, the nearest gallery objects retrieved, the pose reported
registrar.py   the stages in order, and how much work each gets for whole clouds and views
prepared.py    a cloud ready to register (points, tree, features, symmetry halves)
hypothesis.py  a pose with its fit; distinct rotations
fitting.py     refine a pose on one gallery object by ICP and score it
seeding.py     the hypotheses each retrieved candidate contributes (generators: ../hypotheses.py)
upright.py     dropping hypotheses that tip the object when which way is up is known
vote.py        the candidates' vote on the rotation
refinement.py  the final ICP, averaging over agreeing candidates, the mirror-plane finish
"""

from pcrp_core.category.prepared import Prepared, prepare
from pcrp_core.category.registrar import Registrar

__all__ = ['Prepared', 'prepare', 'Registrar']
