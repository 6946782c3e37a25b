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
The benchmark report says why a target is missed from its own run's figures.

Not from numbers written into its prose.
"""

import pytest
from tools.bench import _scale_growth, _scene_note, TARGETS, verdicts, why_unmet
from tools.bench_plots import GROWTH_PLOT, growth_plot, growth_series, slope


def _run(eight_under_5, eight_mean):
    def method(ms, under_5, mean):
        return {
            'median_ms': ms,
            'p95_ms': ms,
            'under_5': under_5,
            'under_10': under_5,
            'err_mean': mean,
            'err_median': 2.0,
        }
    stages = {
        'registration': {'median_ms': 311, 'p95_ms': 350},
        'total': {'median_ms': 337, 'p95_ms': 390},
    }
    methods = {
        'pcrp': method(337, 0.63, 36.4),
        'pcrp_8_candidates': method(219, eight_under_5, eight_mean),
        'pcrp_paper': method(41, 0.27, 71.2),
    }
    return {'queries': [{'threads': '1', 'n_points': 1024, 'stages': stages, 'methods': methods}],
            'verdicts': {TARGETS[0][0]: ('337 ms', False)}}


def test_reasons_quote_this_runs_figures():
    text = ' '.join(why_unmet(_run(0.52, 44.9)))
    for figure in ('311 of its 337 ms', '41 ms', '27%', '63%', '219 ms', '52%', '44.9°', '36.4°'):
        assert figure in text
    assert 'the defaults stay' in text


def test_reasons_do_not_defend_a_default_the_run_contradicts():
    text = ' '.join(why_unmet(_run(0.64, 30.0)))
    assert 'the defaults stay' not in text
    assert 'worth revisiting' in text


def test_no_reason_for_a_met_target():
    run = _run(0.52, 44.9)
    run['verdicts'][TARGETS[0][0]] = ('90 ms', True)
    assert why_unmet(run) == []


def _node_row(topics, workers, age_p95, dropped, lost=0):
    return {'topics': topics, 'workers': workers, 'age_p95_ms': age_p95, 'dropped': dropped,
            'sent': 600, 'received': 600 - lost, 'rate_hz': 10.0 if topics == 1 else 2.0}


def test_the_shipped_node_is_judged_with_a_worker_per_core_and_both_are_shown():
    one = [_node_row(1, 1, 230, 12), _node_row(4, 1, 300, 0)]
    two = [_node_row(1, 2, 160, 0), _node_row(4, 2, 210, 0)]
    said, met = verdicts({'node_shipped': one + two})[TARGETS[4][0]]
    assert met
    assert '1 worker: p95 age 300 ms, 12 dropped' in said and '2 workers: p95 age 210 ms' in said
    for spoilt in (_node_row(4, 2, 260, 0), _node_row(4, 2, 210, 1), _node_row(4, 2, 210, 0, 3)):
        assert not verdicts({'node_shipped': one + two[:1] + [spoilt]})[TARGETS[4][0]][1]
    assert not verdicts({'node_shipped': one})[TARGETS[4][0]][1]


def test_runs_with_a_scene_are_judged_apart_from_those_without(tmp_path):
    plain = [_node_row(1, 2, 160, 0), _node_row(4, 2, 210, 0)]
    scened = [dict(_node_row(1, 2, 240, 0), scene='depth_image', scene_used=590,
                   scene_missing=10),
              dict(_node_row(4, 2, 270, 0), scene='depth_image', scene_used=600,
                   scene_missing=0)]
    run = {'node_shipped': plain + scened}
    run['verdicts'] = verdicts(run)
    assert run['verdicts'][TARGETS[4][0]][1] and not run['verdicts'][TARGETS[5][0]][1]
    assert '270 ms' in run['verdicts'][TARGETS[5][0]][0]
    assert '270 ms' not in run['verdicts'][TARGETS[4][0]][0]
    assert '270 ms at 4 x 2 Hz' in ' '.join(why_unmet(run))
    for r in run['node_shipped']:
        r.update(results_per_s=9.0, age_p50_ms=100.0, rss_start_mb=1, rss_end_mb=1)
    text = '\n'.join(_scene_note(run['node_shipped']))
    assert '1190 of the 1200 clouds' in text
    scened[1]['age_p95_ms'] = 230
    run['verdicts'] = verdicts(run)
    assert run['verdicts'][TARGETS[5][0]][1]
    assert TARGETS[5][0] not in verdicts({'node_shipped': plain})


def test_a_missed_shipped_node_target_is_explained_with_the_views_own_times():
    rows = [_node_row(1, 2, 160, 0), _node_row(4, 2, 262, 0)]
    run = {'node_shipped': rows,
           'views': {'views': {'free': {'pcrp': {'median_ms': 80.0, 'p95_ms': 140.0},
                                        'open3d_ransac_told': {'median_ms': 120.0}}}}}
    run['verdicts'] = verdicts(run)
    text = ' '.join(why_unmet(run))
    assert '80 ms median and 140 ms p95' in text and 'near 220 ms' in text
    assert '262 ms with 2 workers' in text and '160 ms' not in text
    rows[1]['age_p95_ms'] = 240
    run['verdicts'] = verdicts(run)
    assert why_unmet(run) == []


def test_the_growth_plot_fits_each_series_and_the_table_gives_build_time_per_object(tmp_path):
    # a linear series must fit slope 1 and a flat one 0, whichever part of the run it came from
    sizes = [10, 100, 1000, 10000]
    gallery = [{'objects': n, 'match': {'median_ms': 50.0}, 'shortlist': {'median_ms': n / 100}}
               for n in sizes]
    points = [{'points': n, 'estimate': {'median_ms': 60.0}} for n in (1000, 10000)]
    scale = [{'objects': n, 'retrieve': {'median_ms': 40.0, 'p95_ms': 41.0},
              'search': {'median_ms': n / 1000, 'p95_ms': n / 1000}, 'bytes': 14_000 * n,
              'parts': '', 'build_seconds': 0.5 * n} for n in (100, 1000)]
    res = {'views': {'growth': {'gallery': gallery, 'points': points}}, 'scale': scale}
    by_gallery, by_points = growth_series(res)
    fitted = {label: slope(xs, ys) for label, xs, ys in by_gallery + by_points}
    assert len(by_gallery) == 4 and len(by_points) == 1
    assert fitted['YCB view, shortlist (one thread)'] == pytest.approx(1.0)
    assert fitted['YCB view, whole answer (one thread)'] == pytest.approx(0.0, abs=1e-9)
    assert fitted['ModelNet40 search alone'] == pytest.approx(1.0)
    assert growth_plot(res, tmp_path / GROWTH_PLOT)
    assert (tmp_path / GROWTH_PLOT).stat().st_size > 10_000
    lines = _scale_growth(scale)
    assert 'search alone 1.00' in lines[0] and '| 1000 | 500 (0.50) | 14.0 |' in lines
    assert not growth_plot({}, tmp_path / 'none.png')
