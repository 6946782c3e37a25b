# Copyright 2026 The pcrp authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Every setting of a model, defined once: its default, its bounds and a line saying what it does.

Settings are fields of frozen dataclasses declared with `setting(...)`; an instance checks every
value when it is made, so an options object that exists is a valid one. Change settings with
`replace(options, name=value)` (or `PCRP.with_options` / `PCRP.set_params` on a model): the result
is checked again, the original is untouched. The node's parameters, `config/pcrp.yaml` and the
README's parameter table are made from, or tested against, these declarations.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields
import numbers
from typing import Any

import numpy as np


def setting(default, doc: str, *, low=None, high=None, choices=None, low_open: bool = False,
            read_only: bool = False):
    """
    Return a dataclass field with its documentation and bounds.

    Numbers within [low, high] (low excluded when low_open), or one of choices; a tuple default
    takes a list or tuple of values of its elements' type. read_only: fixed once a node has started
    (its parameter says so).
    """
    return field(
        default=default,
        metadata={
            'doc': doc,
            'low': low,
            'high': high,
            'choices': choices,
            'low_open': low_open,
            'read_only': read_only,
        },
    )


def _check(name: str, value, default, meta: dict):
    """
    Return value as the setting holds it (ints stay ints, a float setting takes an int).

    Raise ValueError saying what is expected otherwise.
    """
    kind = type(default)
    if kind is tuple:
        element = type(default[0]) if default else str
        if not isinstance(value, (list, tuple)) or not all(
            isinstance(v, element)
            or (element is float and isinstance(v, int) and not isinstance(v, bool))
            for v in value
        ):
            raise ValueError(f'{name}: expected a list of {element.__name__}, got {value!r}')
        return tuple(element(v) for v in value)
    # numpy's scalars count as the numbers they are (a value read from an array is one)
    if kind is bool:
        if not isinstance(value, (bool, np.bool_)):
            raise ValueError(f'{name}: expected true or false, got {value!r}')
        return bool(value)
    if kind in (int, float):
        if (
            isinstance(value, (bool, np.bool_))
            or not isinstance(value, numbers.Real)
            or (kind is int and not isinstance(value, numbers.Integral))
        ):
            raise ValueError(
                f"{name}: expected {'an integer' if kind is int else 'a number'}, got {value!r}"
            )
        value = kind(value)
        low, high = meta['low'], meta['high']
        if (
            value != value
            or (low is not None and (value <= low if meta['low_open'] else value < low))
            or (high is not None and value > high)
        ):
            raise ValueError(f'{name}: {value!r} is outside {bounds_text(meta)}')
        return value
    if meta['choices'] is not None and value not in meta['choices']:
        raise ValueError(
            f"{name}: expected one of {', '.join(map(str, meta['choices']))}, got {value!r}"
        )
    if not isinstance(value, kind):
        raise ValueError(f'{name}: expected {kind.__name__}, got {value!r}')
    return value


def bounds_text(meta: dict) -> str:
    """How a setting's bounds read in a message or a table: [1, 50], (0, 180], one of ..."""
    if meta.get('choices'):
        return 'one of ' + ', '.join(map(str, meta['choices']))
    low, high = meta.get('low'), meta.get('high')
    if low is None and high is None:
        return ''
    left = '(' if meta.get('low_open') else '['
    return f"{left}{'-inf' if low is None else low}, {'inf' if high is None else high}]"


class Options:
    """Base of the settings dataclasses: checks every field on construction."""

    def __post_init__(self):
        for f in fields(self):
            object.__setattr__(
                self, f.name, _check(f.name, getattr(self, f.name), f.default, f.metadata)
            )

    def replace(self, **changes) -> 'Options':
        unknown = sorted(set(changes) - {f.name for f in fields(self)})
        if unknown:
            raise ValueError(
                f"unknown setting {', '.join(unknown)}; known: "
                f"{', '.join(f.name for f in fields(self))}"
            )
        return dataclasses.replace(self, **changes)

    @classmethod
    def describe(cls) -> list[dict[str, Any]]:
        """One dict per setting: name, default, doc, low, high, low_open, choices."""
        return [{'name': f.name, 'default': f.default, **f.metadata} for f in fields(cls)]


@dataclass(frozen=True)
class QueryOptions(Options):
    """
    What a loaded model does with each cloud.

    With USER_POSE_SETTINGS and USER_INSTANCE_SETTINGS, the settings a user (and the node, as
    parameters) tunes.
    """

    n_candidates: int = setting(
        16,
        'Retrieved gallery objects registered and voted on per cloud (1: the paper).',
        low=1,
        high=50,
    )
    n_matched: int = setting(
        2,
        'Of those, the first ones whose point features seed RANSAC hypotheses (whole '
        'clouds: at most the pose setting whole_matched, and only for a near twin).',
        low=1,
        high=50,
    )
    n_candidates_view: int = setting(
        24,
        'Retrieved gallery objects registered and voted on per cloud from a sensor: a '
        'one-sided view needs more look-alikes to vote.',
        low=1,
        high=50,
    )
    min_confidence: float = setting(
        0.5,
        'Answers less confident than this are rejected (reason low_confidence); '
        'no pose is published for them.',
        low=0.0,
        high=1.0,
    )
    min_points: int = setting(
        32,
        'Clouds with fewer finite points are rejected (reason too_few_points).',
        low=8,
        high=100_000,
    )
    max_points: int = setting(
        1024,
        'Larger clouds are downsampled to this many points, never refused.',
        low=64,
        high=100_000,
    )
    scale_mode: str = setting(
        'metric',
        "metric: clouds in the gallery's units (metres); normalize: clouds of "
        "unknown scale are resized to the gallery's.",
        choices=('metric', 'normalize'),
    )
    method: str = setting(
        'auto',
        'views: match known objects view by view (models built from meshes, clouds from '
        "a camera); pcrp: the paper's pipeline; auto: views where it applies, else pcrp.",
        choices=('auto', 'views', 'pcrp'),
    )
    seed: int = setting(
        0, 'Seed of the random choices (sampling, RANSAC), so answers repeat.', low=0
    )
    cache_size: int = setting(
        256, 'Gallery objects kept prepared for registration between clouds.', low=0
    )

    def __post_init__(self):
        super().__post_init__()
        if self.min_points > self.max_points:
            raise ValueError('min_points must not exceed max_points')


@dataclass(frozen=True)
class PoseOptions(Options):
    """
    How poses are found and chosen (category/, hypotheses.py).

    Settings for experiments more than for users; the paper's pipeline is PAPER_POSE below.
    """

    # the paper's hypotheses: feature matches within symmetry halves, Procrustes in RANSAC
    ransac_iterations: int = setting(
        500, 'RANSAC draws per pairing of symmetry halves.', low=1, high=100_000
    )
    ransac_threshold: float = setting(
        0.08, 'RANSAC inlier distance, normalised units.', low=0.0, low_open=True
    )
    symmetry_split: bool = setting(
        True, 'Match features only within corresponding symmetry halves (the paper).'
    )
    # beyond the paper
    pca_hypotheses: bool = setting(True, 'Also try the principal-axis maps.')
    pca_seeds: int = setting(4, 'Principal-axis maps kept per candidate.', low=1, high=24)
    pca_prefilter: int = setting(
        64, 'Points that rank the 24 axis maps first (0: all of them).', low=0
    )
    flips: bool = setting(
        True, 'Also try the half turns of the best hypothesis about the canonical axes.'
    )
    refine: bool = setting(True, 'Refine poses with ICP.')
    consensus: bool = setting(True, 'Let the retrieved candidates vote on the rotation.')
    consensus_weight: float = setting(
        0.5, "Weight of the candidates' median fit against the best fit in the vote.", low=0.0
    )
    exact_ratio: float = setting(
        0.8,
        'A candidate fitting this much better than all others is the object (whole ' 'clouds).',
        low=0.0,
        high=1.0,
    )
    exact_ratio_view: float = setting(
        0.65,
        'The same for clouds from a sensor, stricter: a partial cloud can fit a '
        'wrong turn of one relative closely.',
        low=0.0,
        high=1.0,
    )
    seeders: int = setting(
        0,
        'Whole clouds: top candidates that seed hypotheses (0: all; at least those matched).',
        low=0,
    )
    seeders_view: int = setting(0, 'The same for clouds from a sensor.', low=0)
    whole_matched: int = setting(
        1,
        'Whole clouds: of the n_matched first candidates, how many seed RANSAC hypotheses from '
        "their point features (a gallery object's features cost as much as the query's), and "
        'only when retrieval found a near twin (whole_matched_ratio). 0: never.',
        low=0,
        high=50,
    )
    whole_matched_ratio: float = setting(
        0.92,
        "Whole clouds: the first candidates get point features only when the first's retrieval "
        "distance is at most this share of the second's: a known object's own descriptor sits "
        'apart, and its features tell its pose from a turn that fits its relatives as well; '
        'for an unseen instance principal axes and half turns find the same poses (1: always).',
        low=0.0,
        high=1.0,
    )
    pool_size: int = setting(6, 'Whole clouds: distinct rotations that go to the vote.', low=1)
    pool_size_view: int = setting(6, 'The same for clouds from a sensor.', low=1)
    reverse_weight: float = setting(
        0.5,
        'Whole clouds: weight of the gallery points far from the posed query (what '
        'is missing is evidence).',
        low=0.0,
    )
    reverse_trim: float = setting(
        1.0, 'Share of those gallery points counted.', low=0.0, high=1.0, low_open=True
    )
    visibility_weight: float = setting(
        1.0,
        'Sensor clouds: weight of the gallery points the sensor would see but the query lacks.',
        low=0.0,
    )
    coarse_icp_iterations: int = setting(
        6, 'ICP iterations per hypothesis before hypotheses are compared.', low=0
    )
    vote_icp_iterations: int = setting(
        6, 'Whole clouds: ICP iterations per hypothesis and candidate before the vote.', low=0
    )
    vote_icp_iterations_view: int = setting(6, 'The same for clouds from a sensor.', low=0)
    vote_survivors: int = setting(
        2,
        'Whole clouds: hypotheses the vote refines in full, after a first round has ranked the '
        'pool on every candidate (0: all of them, in one round).',
        low=0,
    )
    vote_first_iterations: int = setting(
        2, "Whole clouds: ICP iterations of the vote's first round, on the seed points.", low=0
    )
    icp_tolerance: float = setting(
        1e-6, 'ICP stops once the trimmed mean squared error gains less.', low=0.0
    )
    final_ratio: float = setting(
        1.5,
        'Whole clouds: candidates whose fit in the vote is within this factor of the '
        'best are fully refined (the others do not end near the best).',
        low=1.0,
    )
    final_ratio_view: float = setting(float('inf'), 'The same for clouds from a sensor.', low=1.0)
    average_within: float = setting(
        1.15, 'Candidates fitting within this factor of the best are averaged.', low=1.0
    )
    symmetric_iterations: int = setting(
        20, 'Whole clouds: iterations of the final ICP with matches both ways.', low=0
    )
    symmetric_reverse_trim: float = setting(
        0.9, 'Share of gallery-side matches kept there.', low=0.0, high=1.0, low_open=True
    )
    mirror_snap: bool = setting(
        True, "Whole clouds: lay the query's own mirror plane on the gallery object's."
    )
    mirror_tolerance: float = setting(
        1.1,
        'Most residual, in point spacings, of a plane counted as a mirror plane.',
        low=0.0,
        low_open=True,
    )
    mirror_max_deg: float = setting(
        5.0, 'Most turn the mirror-plane finish may make.', low=0.0, high=90.0
    )
    icp_iterations: int = setting(20, 'ICP iterations of the final refinement.', low=0)
    icp_trim: float = setting(
        0.8, 'Share of closest matches each ICP iteration keeps.', low=0.0, high=1.0, low_open=True
    )
    icp_trim_view: float = setting(
        1.0,
        'The same for clouds from a sensor: a view is a part of its object, so every point of it '
        'has a match to keep.',
        low=0.0,
        high=1.0,
        low_open=True,
    )
    icp_points: int = setting(256, 'Query points used by ICP and scoring.', low=16)
    coarse_points: int = setting(256, 'Query points hypotheses are told apart on.', low=16)
    seed_points: int = setting(
        128,
        'Whole clouds: query points each candidate first refines and ranks its hypotheses on '
        '(the vote judges the best of them on coarse_points).',
        low=16,
    )
    inlier_distance: float = setting(
        0.05,
        'Distance under which a query point counts as on the model, normalised ' 'units.',
        low=0.0,
        low_open=True,
    )
    up_tolerance_deg: float = setting(
        60.0,
        'With an up direction: how far an answer may tip the object from upright.',
        low=1.0,
        high=180.0,
    )
    upright_turns: int = setting(
        12, 'Turns about the vertical tried when nothing else is upright.', low=1
    )
    view_seeders: int = setting(
        4, 'Sensor clouds: candidates that also get view hypotheses.', low=0
    )
    view_directions: int = setting(
        20, 'Directions the sensor may have stood in, per view-seeded candidate.', low=1
    )
    view_rolls: int = setting(12, 'Rolls about the line of sight per direction.', low=1)
    view_keep: int = setting(2, 'View hypotheses kept per candidate.', low=1)
    view_prefilter: int = setting(32, 'Points the view hypotheses are ranked on.', low=1)


@dataclass(frozen=True)
class InstanceOptions(Options):
    """
    How known objects are matched view by view (pcrp_core/instance).

    Settings for experiments.
    """

    shortlist: int = setting(
        8, "Objects whose views have the query's shape that are looked at further.", low=1
    )
    smaller_weight: float = setting(
        0.5,
        "Shortlist: weight of the query's being smaller than a view along an axis, against its "
        'being larger (something in front of an object cuts its view down; nothing makes it '
        'show more).',
        low=0.0,
        high=1.0,
    )
    silhouette_poses: int = setting(
        16, '(view, roll) poses per object from the best-agreeing silhouettes.', low=1
    )
    yaw_steps: int = setting(
        36, 'With gravity known: turns about the vertical tried per object.', low=1
    )
    score_points: int = setting(48, 'Query points the hypotheses are ranked on.', low=8)
    poses_refined: int = setting(2, 'Best hypotheses per object refined by ICP.', low=1)
    poses_refined_again: int = setting(
        2,
        'An answer that fits poorly (local_shape_cost) first has this many more hypotheses '
        'of each of the best objects refined: the right pose is often ranked just past the '
        'first few; 0: none.',
        low=0,
    )
    objects_refined: int = setting(
        7, 'Objects, best-ranked first, whose hypotheses are refined and judged.', low=1
    )
    coarse_ratio: float = setting(
        1.6,
        'Of those, only objects whose best hypothesis costs at most this many times the '
        "best object's.",
        low=1.0,
    )
    refine_points: int = setting(384, 'Query points ICP uses.', low=16)
    half_turns: bool = setting(
        True,
        "Also refine the answer turned half about each of its object's principal axes "
        '(about the up axis alone when gravity is given), keeping the best fit.',
    )
    local_shape_cost: float = setting(
        0.5,
        'Clouds matched view by view: an answer costing more than this (a poor fit: the object '
        'partly hidden, or not in the gallery) is looked for again by matched local shape (FPFH '
        'in RANSAC), which finds more partly hidden objects but takes several times as long; '
        '.inf (infinity) never.',
        low=0.0,
    )
    local_shape_cost_hidden: float = setting(
        0.25,
        'The same for an answer the scene (scene_topics) shows partly hidden (a tenth or more of '
        'the surface it would show lies behind something nearer): that surface is excused, so a '
        'poor fit costs less, and the view hypotheses saw a cut silhouette; .inf never.',
        low=0.0,
    )
    drop_strays: bool = setting(
        True,
        'Clouds matched view by view: first set aside the points lying apart from the object '
        "(background pixels a mask took in, flying pixels at the object's edges, a speck of "
        'something else), which otherwise throw the answer off.',
    )
    drop_support: bool = setting(
        False,
        'Clouds matched view by view with up known: first set aside the table a mask took in '
        "around the object's foot, the cloud's lowest layer where it is crowded as a plane seen "
        'across (not in flat views). For a segmenter whose masks take in the table: it costs '
        'partly hidden objects and the rejection of unknown ones (docs/method.md).',
    )
    local_shape_objects: int = setting(
        12, "Objects looked for then: those whose views have the cloud's shape, nearest first.",
        low=1,
    )
    local_shape_min_diameter: float = setting(
        0.9,
        'Of those, only objects whose diameter is at least this share of the extent of the '
        "cloud's middle 99 % along its principal axes: a view shows at most all of its object. "
        '0: all.',
        low=0.0,
        high=1.0,
    )
    local_shape_voxel: float = setting(
        0.005, 'Grid, metres, both clouds are thinned on for it.', low=0.0, low_open=True
    )
    local_shape_radius: float = setting(
        0.025, 'Radius, metres, of the surface patch each FPFH describes.', low=0.0,
        low_open=True,
    )
    local_shape_iterations: int = setting(5000, 'RANSAC draws per object.', low=1)
    fit_tolerance: float = setting(
        0.003,
        'Least distance, metres, beyond which a point counts as unexplained.',
        low=0.0,
        low_open=True,
    )
    unshown_weight: float = setting(
        1.0,
        'Cost of an expected surface point missing from the cloud against that of '
        'a cloud point off the object.',
        low=0.0,
    )
    noise_tolerance: float = setting(
        2.5, "That distance as a multiple of the cloud's own range noise, when larger.", low=0.0
    )


# the pose settings a user tunes beside QueryOptions (the node's parameters)
USER_POSE_SETTINGS = ('refine', 'up_tolerance_deg')
# and the view-by-view ones: when to look again by local shape, time traded for partly hidden
# objects (docs/node.md), and whether a view's strays are set aside (for a segmenter known clean)
USER_INSTANCE_SETTINGS = (
    'local_shape_cost', 'local_shape_cost_hidden', 'drop_strays', 'drop_support'
)

# The paper's registration: feature matches within the symmetry halves, Procrustes in RANSAC,
# the best-fitting of those hypotheses; one retrieved object, no principal-axis, half-turn or
# view hypotheses, no candidate vote, no ICP, no rejection.
PAPER_POSE = PoseOptions(
    pca_hypotheses=False,
    flips=False,
    view_seeders=0,
    refine=False,
    consensus=False,
    seeders=1,
    seeders_view=1,
    whole_matched=1,
    whole_matched_ratio=1.0,
    seed_points=256,
    reverse_weight=0.0,
)
PAPER_QUERY = {'n_candidates': 1, 'n_candidates_view': 1, 'n_matched': 1, 'min_confidence': 0.0}


def user_settings() -> list[dict[str, Any]]:
    """Return the settings a user tunes on a loaded model, as Options.describe() gives them."""
    pose = [d for d in PoseOptions.describe() if d['name'] in USER_POSE_SETTINGS]
    instance = [d for d in InstanceOptions.describe() if d['name'] in USER_INSTANCE_SETTINGS]
    return QueryOptions.describe() + pose + instance
