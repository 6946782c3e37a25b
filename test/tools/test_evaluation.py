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
Test `python -m tools paper-eval`.

The protocols and measures it rests on, and the command end to end on real data.
"""

import json
import subprocess
import sys

from helpers import MODELNET, modelnet, PROCEDURAL_MODEL, REPO, rotation_error_deg
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from tools.paper_eval.metrics import (chamfer, euler_errors, geodesic_deg, mse_rmse_mae,
                                      pose_error, precision_at_10)
from tools.paper_eval.protocol import make_query, query_rng


def test_geodesic_and_euler_errors_measure_known_rotations():
    R = Rotation.from_euler('xyz', [10, 20, 30], degrees=True).as_matrix()
    assert geodesic_deg(R, R) == pytest.approx(0, abs=1e-5)
    turn = Rotation.from_euler('z', 25, degrees=True).as_matrix()
    assert geodesic_deg(turn @ R, R) == pytest.approx(25, abs=1e-6)
    # 179° and -179° are 2° apart, not 358°
    a = Rotation.from_euler('xyz', [179, 0, 0], degrees=True).as_matrix()
    b = Rotation.from_euler('xyz', [-179, 0, 0], degrees=True).as_matrix()
    assert np.abs(euler_errors(a, b)).max() == pytest.approx(2, abs=1e-6)
    assert mse_rmse_mae([[3, -4], [0, 0]]) == pytest.approx(
        {'mse': 6.25, 'rmse': 2.5, 'mae': 1.75}
    )


def test_labels_either_way_forgive_turns_about_the_up_axis_of_airplanes_and_cars_only():
    R = Rotation.from_euler('xyz', [10, 20, 30], degrees=True).as_matrix()
    for angle in (90, 180, 270):
        # answered in the frame of a gallery object whose labels are turned against the query's
        quarter = R @ Rotation.from_euler('z', angle, degrees=True).as_matrix()
        car = pose_error(quarter, R, 'car')
        assert car['error'] == pytest.approx(min(angle, 360 - angle), abs=1e-4)
        assert car['tolerant'] == pytest.approx(0, abs=1e-4)
        chair = pose_error(quarter, R, 'chair')
        assert chair['tolerant'] == chair['error'] == pytest.approx(car['error'])
    # a turn about another axis, or a small one, is an error whatever the labels
    tipped = R @ Rotation.from_euler('x', 90, degrees=True).as_matrix()
    assert pose_error(tipped, R, 'airplane')['tolerant'] == pytest.approx(90, abs=1e-4)
    near = R @ Rotation.from_euler('z', 97, degrees=True).as_matrix()
    assert pose_error(near, R, 'airplane')['tolerant'] == pytest.approx(7, abs=1e-4)


def test_rejection_shares_count_a_label_turn_as_right_only_up_to_the_labels():
    from tools.paper_eval.pose_table import rejection_summary

    def row(category, error, tolerant, rejected):
        return {'category': category, 'retrieved_category': category, 'confidence': 0.5,
                'rejected': rejected, 'pcrp': {'error': error, 'tolerant': tolerant}}
    inside = [row('car', 180.0, 1.0, False), row('chair', 2.0, 2.0, True),
              row('sofa', 170.0, 170.0, False), row('airplane', 90.0, 3.0, True)]
    s = rejection_summary(inside, [row('lamp', 50.0, 50.0, True)])
    assert s['inside_wrong_but_accepted'] == pytest.approx(0.5)
    assert s['tolerant']['inside_wrong_but_accepted'] == pytest.approx(0.25)
    assert s['inside_right_but_rejected'] == pytest.approx(0.25)
    assert s['tolerant']['inside_right_but_rejected'] == pytest.approx(0.5)
    assert s['tolerant']['inside_right_among_accepted'] == pytest.approx(0.5)
    assert s['outside_rejected'] == 1.0


def test_precision_at_10_reads_both_definitions():
    chamfers = np.arange(200, dtype=float)       # object i is the i-th nearest
    ranked = np.r_[
        0:5, 15:20, 100:190
    ]  # 5 of the 10 nearest, the rest within the nearest 10 % (20)
    assert precision_at_10(ranked, chamfers) == (0.5, 1.0)
    assert precision_at_10(np.arange(199, -1, -1), chamfers) == (0.0, 0.0)


def test_chamfer_is_zero_on_the_same_cloud_and_grows_with_distance():
    p = np.random.default_rng(0).normal(size=(300, 3))
    assert chamfer(p, p[::-1]) == 0
    assert chamfer(p, p + [0.1, 0, 0]) < chamfer(p, p + [0.3, 0, 0])


@pytest.mark.skipif(not MODELNET.exists(), reason='needs ../shared/data/modelnet40')
def test_queries_are_fixed_by_the_seed_and_move_the_object_as_stated():
    p = modelnet('chair', 'test', 1)[0][0]
    a = make_query('c', 'chair', p, query_rng(0, 'pose/c', 0), 'uniform', 'view')
    b = make_query('c', 'chair', p, query_rng(0, 'pose/c', 0), 'uniform', 'view')
    c = make_query('c', 'chair', p, query_rng(1, 'pose/c', 0), 'uniform', 'view')
    assert np.array_equal(a.points, b.points) and not np.array_equal(a.R, c.R)
    assert len(a.points) < len(p)                          # one side only
    whole = make_query('c', 'chair', p, query_rng(0, 'x', 0), 'euler45')
    moved = p @ whole.R.T + whole.t
    assert chamfer(whole.points, moved) < 1e-9             # the same points, shuffled
    angles = Rotation.from_matrix(whole.R).as_euler('xyz', degrees=True)
    assert np.all((angles >= 0) & (angles <= 45))


def test_a_gallery_subset_answers_from_its_own_objects_only():
    from pcrp_core import PCRP
    from pcrp_core.sources.procedural import generate_object
    model = PCRP.load(PROCEDURAL_MODEL)
    sofas = [g for g, c in zip(model.gallery.ids, model.gallery.categories) if c == 'sofa']
    sub = model.subset(sofas)
    chair = generate_object('chair', 1234)     # a chair the gallery does not hold
    assert all(g in sofas for g, _ in sub.retrieve(chair, k=5))
    # a gallery object of the subset, moved, comes back as itself
    R = Rotation.from_euler('xyz', [30, -50, 120], degrees=True).as_matrix()
    r = sub.estimate(model.gallery_cloud(sofas[3]) @ R.T + [0.2, 0, -0.1])
    assert r.gallery_id == sofas[3] and rotation_error_deg(r.rotation, R) < 2
    with pytest.raises(ValueError):
        model.subset([])


def test_the_frame_audit_summarises_how_a_category_s_objects_are_turned():
    from tools.paper_eval import frames
    rows = [
        {
            'name': 'a',
            'category': 'car',
            'nearest_agrees': True,
            'share_agreeing': 0.5,
            'nearest_turn_deg': 0.0,
        },
        {
            'name': 'b',
            'category': 'car',
            'nearest_agrees': False,
            'share_agreeing': 0.1,
            'nearest_turn_deg': 90.0,
        },
    ]
    d = frames.summarise(rows)['car']
    assert d['nearest_agrees'] == 0.5 and d['quarter_turns'] == 0.5 and d['half_turns'] == 0.0
    assert d['look_alike_mean_deg'] == 45.0 and d['look_alike_median_deg'] == 45.0


def test_the_long_side_check_tells_which_way_the_labels_lay_an_elongated_object():
    from tools.paper_eval import frames
    rng = np.random.default_rng(0)
    cube = rng.uniform(-1, 1, (64, 3))
    clouds = np.stack([cube * [1.0, 0.4, 0.3], cube * [0.4, 1.0, 0.3], cube * [1.0, 0.8, 0.3]])
    along_y = frames.long_side_along_y(clouds)
    # the third is barely longer than wide: which side is longer says nothing about the labels
    assert along_y[:2].tolist() == [0.0, 1.0] and np.isnan(along_y[2])


def test_the_bar_names_the_labels_bound_and_a_tie_at_the_quarter_turn():
    from tools.paper_eval import report

    def errs(mean, median):
        return {'mean': mean, 'median': median}

    res = {
        'pose': {
            'uniform': {
                'summary': {
                    'car': {'pcrp': {**errs(70.5, 89.9), 'tolerant': errs(4.2, 1.1)},
                            'ransac_icp': {**errs(88.7, 89.8), 'tolerant': errs(9.0, 0.9)}},
                    'chair': {'pcrp': errs(9.9, 1.6), 'ransac_icp': errs(32.2, 4.3)},
                }
            }
        },
        'frames': {
            'summary': {
                'car': {
                    'nearest_agrees': 0.38,
                    'look_alike_mean_deg': 73.8,
                    'look_alike_median_deg': 90.0,
                },
                'chair': {
                    'nearest_agrees': 1.0,
                    'look_alike_mean_deg': 0.0,
                    'look_alike_median_deg': 0.0,
                },
            }
        },
    }
    rows = {line.split('|')[1].strip(): line for line in report.bar(res)[2:] if line}
    car, chair = rows['pose, car, uniform rotations'], rows['pose, chair, uniform rotations']
    assert (
        'paper: **no** (labels: perfect registration to the nearest look-alike scores 73.8° / '
        '90.0°)'
        in car
    )
    assert 'classical: **no** (both medians at the quarter turn)' in car
    assert '70.5° / 89.9° (labels either way: 4.2° / 1.1°)' in car
    # up to the labels the paper's 11.22° / 2.11° is beaten, Open3D's median 0.9° is not
    assert 'labels either way: paper yes, classical **no** |' in car
    assert 'paper: yes; classical: yes |' in chair and 'labels' not in chair


@pytest.mark.skipif(not MODELNET.exists(), reason='needs ../shared/data/modelnet40')
@pytest.mark.slow
def test_pcrp_eval_quick_writes_the_report_with_every_experiment(tmp_path):
    out = tmp_path / 'results'
    proc = subprocess.run(
        [
            sys.executable,
            '-m',
            'tools',
            'paper-eval',
            '--quick',
            '--data',
            str(MODELNET),
            '--out',
            str(out),
            '--cache',
            str(tmp_path / 'cache'),
        ],
        capture_output=True,
        text=True,
        timeout=900,
        env={**__import__('os').environ, 'TQDM_DISABLE': '1'},
        cwd=REPO,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    text = (out / 'RESULTS.md').read_text()
    for heading in (
        '## The bar',
        '## What the data allows',
        '## Pose estimation',
        '### The narrower protocol',
        '## Partial views',
        '## Registration',
        '## Retrieval',
        '## A larger gallery',
        '## Rejection',
        '## Held-out check',
        '### The same objects under other draws of the rotations',
    ):
        assert heading in text
    assert (out / 'pose_cdf.png').stat().st_size > 10_000 and (
        out / 'pose_examples.png'
    ).stat().st_size > 10_000
    res = json.loads((out / 'results.json').read_text())
    # registering an object to a moved copy of its own points is exact for the feature methods
    for m in ('r_pointhop', 'fr_pointhop', 'fr_pointhop_ext'):
        assert res['registration']['full'][m]['rotation']['mae'] < 1.0
    for setting in ('aligned', 'arbitrary'):
        d = res['retrieval'][setting]
        assert d['best_top1_chamfer'] <= min(
            d[m]['top1_chamfer'] for m in ('pcrp_vlad', 'pcrp_max', 'fpfh_vlad')
        )
    # the held-out check's queries are train objects its model was built without
    from pcrp_core import PCRP
    held = {r['name'] for r in res['holdout']['rows']}
    from tools.paper_eval.protocol import load_split
    train = {
        n
        for c in ('airplane', 'chair', 'sofa', 'car')
        for n in load_split(MODELNET, c, 'train')[0]
    }
    assert len(held) == 8 and held <= train
    assert not held & set(PCRP.load(tmp_path / 'cache' / 'model4_holdout_quick').gallery_ids)
    # told which way is up: a column of the held-out check and of the robot's views table, not of
    # the paper's
    assert all('pcrp_up' in r for r in res['holdout']['rows'])
    assert (
        'pcrp_up' in res['partial_views']['view']['summary']['all']
        and 'told which way is up' in text
    )
    assert 'pcrp_up' not in res['pose']['uniform']['summary']['all']
    uniform = res['pose']['uniform']['summary']
    assert uniform['all']['pcrp']['n'] == 8 and set(uniform['all']) >= {
        'pcrp',
        'pcrp_paper',
        'icp',
        'fgr_icp',
        'ransac_icp',
    }
    # the other draws rotate the same objects otherwise: same queries, other errors
    from tools.paper_eval.run import OTHER_SEEDS
    assert sorted(res['seeds']) == [str(res['seed'] + k) for k in OTHER_SEEDS]
    draws = [uniform] + list(res['seeds'].values())
    assert all(d['all']['pcrp']['n'] == 8 for d in draws)
    assert len({d['all']['pcrp']['mean'] for d in draws}) == len(draws)
    # the package's extensions (candidate vote, half turns, ICP) over the paper's bare registration
    assert uniform['all']['pcrp']['median'] < uniform['all']['pcrp_paper']['median']


def test_the_paper_variant_tries_only_the_papers_hypotheses():
    """
    The paper's row must stay the paper's method as this package grows new hypotheses.

    On a one-sided view with its sensor position (where view hypotheses would join in) every
    hypothesis comes from RANSAC on feature matches.
    """
    from pcrp_core import PCRP
    from pcrp_core.category import Registrar
    from pcrp_core.config import PoseOptions
    from pcrp_core.sources.procedural import generate_object
    from pcrp_core.sources.views import partial_view
    from tools.paper_eval.methods import _prepared, PAPER_OPTIONS
    model = PCRP.load(None)
    rng = np.random.default_rng(0)
    p = generate_object('chair', 3).astype(np.float64)
    seen, camera = partial_view(p, rng, 0.005, with_camera=True)
    (c_q, q), (_, g) = _prepared(model.pointhop, model.unit, seen), _prepared(
        model.pointhop, model.unit, p
    )
    viewpoint = (camera - c_q) / model.unit

    def sources(options):
        return {
            h.source.split('+')[0]
            for h in Registrar(q, options, rng, viewpoint=viewpoint).seeds(g)
        }

    assert sources(PAPER_OPTIONS) == {'ransac'}
    assert sources(PoseOptions()) >= {'ransac', 'view', 'pca'}


def test_a_partial_run_carries_the_rest_of_an_earlier_one_and_says_so():
    from tools.paper_eval.run import carry
    earlier = {
        'seed': 0,
        'date': 'then',
        'seconds': {'frames': 1.0, 'total': 9.0},
        'frames': {'a': 1},
        'pose': {'uniform': 'old', 'view': 'old view'},
    }
    res = {
        'seed': 0,
        'date': 'now',
        'seconds': {'pose': 2.0, 'total': 2.0},
        'pose': {'uniform': 'new'},
    }
    out = carry(res, earlier)
    assert out['frames'] == {'a': 1} and out['pose'] == {'uniform': 'new', 'view': 'old view'}
    assert out['carried'] == {'frames': 'then', 'pose/view': 'then'}
    assert out['seconds'] == {'frames': 1.0, 'pose': 2.0, 'total': 2.0}
    # carried twice: an experiment keeps the date it was run on, not the date it was carried on
    again = carry({'seed': 0, 'date': 'later', 'seconds': {'total': 1.0}}, out)
    assert again['carried'] == {'frames': 'then', 'pose/view': 'then', 'pose/uniform': 'now'}
    with pytest.raises(ValueError, match='seed'):
        carry(res, {**earlier, 'seed': 1})


def test_the_confidence_section_judges_reliability_by_the_labels_and_either_way(tmp_path):
    from tools.paper_eval import confidence_table as ct, report
    rng = np.random.default_rng(0)
    rows = []
    for i in range(80):
        inside, c = i < 60, float(rng.uniform())
        right = inside and c > 0.5
        rows.append({'kind': 'whole' if i % 2 else 'view', 'inside': inside, 'confidence': c,
                     'right': right and i % 3 > 0, 'right_tolerant': right})
    conf = {'threshold': 0.5, 'summary': ct.summarise(rows, 0.5),
            'summary_tolerant': ct.summarise(rows, 0.5, 'right_tolerant')}
    text = '\n'.join(report.confidence_md(conf, tmp_path))
    assert '| mean confidence in bin | share right | share right, labels either way | answers |' \
        in text
    # the bins are the same answers: only the share right differs between the two columns
    table = [line.split(' | ') for line in text.splitlines() if line.startswith('| 0.')]
    assert table and any(float(raw) < float(either) for _, raw, either, _ in table)
    assert (tmp_path / 'confidence.png').stat().st_size > 0
