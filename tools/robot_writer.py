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
ROBOT.md, robot.json and the figures from robot_report.run's results.

Every figure in the text is computed here from the per-view records, so re-rendering from a
robot.json (`--from-json`) gives the same report, and no sentence can drift from its numbers.
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from pcrp_core.confidence import expected_calibration_error, reliability
from pcrp_core.evaluation import metrics
from pcrp_core.evaluation.run import (cell, COLUMNS, jsonable, statistics, summarise,
                                      unknown_statistics)
from pcrp_core.evaluation.scenes import DISTANCE, ELEVATION_DEG, MIN_PIXELS, OCCLUDED_SHARE
from pcrp_core.instance.calibration import CALIBRATION_SEED
from pcrp_core.sources.camera import PinholeCamera, RangeNoise
from tools.robot_protocol import SEEDS, VIEWS_PER_OBJECT

FILES = {'test': 'robot', 'validation': 'robot_validation'}
SCENARIO_TITLES = {'free': 'free in space', 'table': 'on a table, up known',
                   'free_occluded': 'free, occluded',
                   'table_occluded': 'on a table, occluded, up known',
                   'free_occluded_seen': 'free, occluded, occluder seen',
                   'table_occluded_seen': 'on a table, occluded, occluder seen, up known'}
ONE_SIDED = ('free', 'table')   # the "one-sided YCB views": whole, unoccluded
TOLD = ('ransac_told', 'fgr_told')
THRESHOLDS = (0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)
# the bars for confidence and unknown objects
TARGETS = {'unknown_rejected': 0.80, 'unknown_auc': 0.95, 'wrong_accepted': 0.05,
           'right_rejected': 0.05}
# and for the answers themselves, per scenario: right object, pose right (higher when up is known)
RIGHT_OBJECT = 0.95
POSE_RIGHT = {'free': 0.95, 'table': 0.97}
# What was chosen on validation views (seed 1000) while the harness was written, and what it
# measured; the test views were not looked at until these were fixed.
CHOICES = [
    "ICP of the Open3D pipelines: point-to-plane within 1.5 voxels instead of the tutorial's "
    '0.4: told the object, 98 % of 52 validation views right against 90 % for FPFH + RANSAC + '
    'ICP, 85 % against 58 % for FPFH + FGR + ICP',
    "RANSAC's iteration cap kept at the tutorial's 100,000 (confidence 0.999): 10,000 was 2.4x "
    'faster with own retrieval but right on 88 % instead of 96 % of 26 validation views told '
    'the object, and picked the right object on 65 % instead of 73 %',
    'the size gate of the own-retrieval variants (a gallery object is registered only if its '
    "diameter is between 0.87 and 2 times the view's extent): it kept the true object for "
    '99.5 % of 624 validation views (occluded ones included) and 28 of 78 objects on average, '
    'which made the run about 2.8x shorter',
]
SIZE_BINS = ((0.0, 0.07, '< 7 cm'), (0.07, 0.12, '7-12 cm'), (0.12, 0.2, '12-20 cm'),
             (0.2, 10.0, '> 20 cm'))
STAT_KEYS = [k for k, _, _ in COLUMNS if k != 'views']
STAT_TITLES = [t for k, t, _ in COLUMNS if k != 'views']


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ['| ' + ' | '.join(header) + ' |', '| ' + ' | '.join('---' for _ in header) + ' |']
    return '\n'.join(lines + ['| ' + ' | '.join(r) + ' |' for r in rows])


def _pct(x) -> str:
    return '-' if x is None or not np.isfinite(x) else f'{100 * x:.0f} %'


def _pct1(x) -> str:
    """
    Return a share to a tenth of a percent.

    Where it is held against a bar, 5 % must not hide 5.4.
    """
    return '-' if x is None or not np.isfinite(x) else f'{100 * x:.1f} %'


def _num(x, digits: int = 2) -> str:
    return '-' if x is None or not np.isfinite(x) else f'{x:.{digits}f}'


def _title(name: str) -> str:
    return SCENARIO_TITLES.get(name, name)


def _stat_cells(method: str, s: dict) -> list[str]:
    cells = [cell(k, s.get(k)) for k in STAT_KEYS]
    if method in TOLD:
        cells[0] = cells[1] = '(told)'
    return cells


def _each_view_once(res: dict) -> list[str]:
    """Name the scenarios "all" pools: not those that answer the occluded views again, seen."""
    return [n for n, v in res['scenarios'].items() if not (len(v) > 3 and v[3])]


def _pooled(res: dict, method: str, names=None) -> list[dict]:
    names = _each_view_once(res) if names is None else names
    return [r for n, rows in res['results'].items() if n in names for r in rows.get(method, [])]


def _baseline_views_only(rows: list[dict], res: dict) -> list[dict]:
    return [r for r in rows if r['view'] < res['baseline_views']]


def _min_confidence(res: dict) -> float:
    return res['model']['options'].get('min_confidence', 0.5)


def _answered(rows):
    return [r for r in rows if r['gallery_id'] is not None]


def _confidences(rows: list[dict]) -> tuple[list[float], list[float]]:
    """Confidences of the right answers and of the wrong ones (views without an answer out)."""
    answered = _answered(rows)
    return ([r['confidence'] for r in answered if r['pose_right']],
            [r['confidence'] for r in answered if not r['pose_right']])


def _unknown_split(res: dict, names=None):
    """
    (known rows, unknown rows, unknown rows with a look-alike left, without) of the held-out model.

    Of the scenarios named (None: each view once).
    """
    names = _each_view_once(res) if names is None else names
    rows = [r for n, per in res['unknown'].items() if n in names for r in per]
    near = res['held_out']['lookalikes']
    known = [r for r in rows if r['known']]
    unknown = [r for r in rows if not r['known']]
    return (known, unknown, [r for r in unknown if r['object_id'] in near],
            [r for r in unknown if r['object_id'] not in near])


def _unknown_auc(known: list[dict], unknown: list[dict]) -> float:
    """
    ROC AUC of confidence.

    The held-out model's right answers on known objects against its answers on unknown ones (which
    are all wrong, whatever they name).
    """
    return unknown_statistics(known, unknown).get('auc', math.nan)


def _unknown_rejected(rows: list[dict], threshold: float) -> float:
    return unknown_statistics([], rows, threshold).get('rejected', math.nan)


# -- figures ------------------------------------------------------------------------------------
def _figure(n_panels: int, grid: bool = False):
    """Return a row of panels, or (grid) two columns of them, for figures read panel by panel."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    rows, cols = ((n_panels + 1) // 2, min(2, n_panels)) if grid else (1, n_panels)
    fig, axes = plt.subplots(rows, cols, figsize=(4.6 * cols, 4.2 * rows), squeeze=False)
    axes = axes.ravel()
    for ax in axes[n_panels:]:
        ax.set_visible(False)
    return plt, fig, axes[:n_panels]


def plot_adds(res: dict, path: Path) -> None:
    thresholds = np.linspace(0.0, metrics.AUC_MAX, 201)
    names = list(res['results'])
    plt, fig, axes = _figure(len(names))
    for ax, name in zip(axes, names):
        ax.set_ylim(0, 1.02)
        for method, label in res['methods'].items():
            if method not in res['results'][name]:
                continue
            rows = res['results'][name][method]
            ax.plot(thresholds * 100,
                    metrics.share_below([r['surface_error'] for r in rows], thresholds),
                    ls='--' if method in TOLD else '-', label=f'{label} ({len(rows)})')
        ax.set_title(_title(name), fontsize=10)
        ax.set_xlabel('ADD-S threshold (cm)')
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, loc='lower right')
    axes[0].set_ylabel('share of views with ADD-S below')
    fig.suptitle('YCB objects, depth-camera views: share posed within each ADD-S (right object '
                 'or twin; views per method in brackets)', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_reliability(res: dict, path: Path) -> None:
    names = list(res['results'])
    plt, fig, axes = _figure(len(names), grid=True)
    for ax, name in zip(axes, names):
        ax.plot([0, 1], [0, 1], color='grey', lw=0.8, ls=':')
        known = _answered(res['results'][name]['pcrp'])
        mixed = _answered(res['unknown'][name])
        for rows, label, colour in ((known, 'known objects', 'C0'),
                                    (mixed, 'held-out model: known + unknown', 'C3')):
            bins = reliability([r['confidence'] for r in rows], [r['pose_right'] for r in rows])
            if not bins:
                continue
            c, s, k = (np.array(v) for v in zip(*bins))
            ax.plot(c, s, '-o', color=colour, ms=3, label=label)
            for x, y, n in zip(c, s, k):
                ax.annotate(str(n), (x, y), fontsize=6, color=colour, xytext=(2, 3),
                            textcoords='offset points')
        ax.set_title(_title(name), fontsize=10)
        ax.set_xlabel('confidence (bin mean)')
        ax.set_xlim(0, 1)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    for ax in axes[::2]:
        ax.set_ylabel('share right')
    axes[0].legend(fontsize=7, loc='upper left')
    fig.suptitle("pcrp's confidence against how often it is right, in 10 bins (numbers: answers "
                 'in the bin)', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_roc(res: dict, path: Path) -> None:
    names = list(res['results'])
    plt, fig, axes = _figure(len(names), grid=True)
    for ax, name in zip(axes, names):
        ax.plot([0, 1], [0, 1], color='grey', lw=0.8, ls=':')
        curves = [(_confidences(res['results'][name]['pcrp']), 'pcrp: right vs wrong', 'C0-')]
        known, unknown, _, _ = _unknown_split(res, (name,))
        curves.append((([r['confidence'] for r in _answered(known) if r['pose_right']],
                        [r['confidence'] for r in _answered(unknown)]),
                       'pcrp: right vs unknown object', 'C3-'))
        if 'ransac' in res['results'][name]:
            curves.append((_confidences(res['results'][name]['ransac']),
                           'RANSAC retrieval fitness: right vs wrong', 'C2--'))
        for (pos, neg), label, style in curves:
            if pos and neg:
                fpr, tpr = metrics.roc_curve(pos, neg)
                ax.plot(fpr, tpr, style, label=f'{label} (AUC {metrics.roc_auc(pos, neg):.2f})')
        ax.set_title(_title(name), fontsize=10)
        ax.set_xlabel('share of wrong (or unknown) accepted')
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, loc='lower right')
    for ax in axes[::2]:
        ax.set_ylabel('share of right accepted')
    fig.suptitle('ROC of the confidence: every threshold, what is accepted', fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- tables -------------------------------------------------------------------------------------
def _overall(res: dict, summaries: dict) -> str:
    rows = []
    # pcrp again on the views the baselines answered, where they ran (0: none) on fewer views
    reduced = 0 < res['baseline_views'] < res['views_per_object']
    for name, per_method in summaries.items():
        for method, s in per_method.items():
            rows.append([_title(name), res['methods'][method]]
                        + _stat_cells(method, s['overall']))
            if method == 'pcrp' and reduced:
                sub = statistics(_baseline_views_only(res['results'][name]['pcrp'], res))
                rows.append([_title(name), "pcrp on Open3D's views only"]
                            + _stat_cells(method, sub))
    return _table(['scenario', 'method'] + STAT_TITLES, rows)


def _headline(res: dict, summaries: dict) -> str:
    """
    One row per scenario.

    What pcrp gets right, how its confidence sorts it, how fast, and the baselines' pose right
    beside it (on their views).
    """
    threshold = _min_confidence(res)
    base = [m for m in ('ransac', 'fgr', 'ransac_told') if m in res['methods']]
    rows = []
    for name, per in summaries.items():
        s = per['pcrp']['overall']
        unknown = [r for r in res['unknown'][name] if not r['known']]
        rows.append([_title(name), _pct(s['right_object']), _pct(s['right_or_twin']),
                     _pct(s['pose_right']), _pct(s['wrong_accepted']), _pct(s['right_rejected']),
                     _num(s['confidence_auc']), _pct(_unknown_rejected(unknown, threshold)),
                     f"{s['seconds_median']:.2f} / {s['seconds_p95']:.2f} s"]
                    + [_pct(per[m]['overall']['pose_right']) if m in per else '-' for m in base])
    header = ['scenario', 'right obj', 'obj or twin', 'pose right', 'wrong acc', 'right rej',
              'conf AUC', 'unknown rejected', 'time med / p95']
    header += [{'ransac': 'RANSAC retrieval: pose right', 'fgr': 'FGR retrieval: pose right',
                'ransac_told': 'RANSAC told: pose right'}[m] for m in base]
    return (f'pcrp with its defaults (min_confidence {threshold}); unknown rejected: the share of '
            "the held-out objects' views the model built without them rejects"
            + ("; Open3D's columns are its pose right on the views it answered" if base else '')
            + '. Details and definitions below.\n\n'
            + _table(header, rows))


def _bar(res: dict, summaries: dict) -> str:
    """
    Return the issues' bars for one-sided views of known objects, each with what was measured.

    Open3D told the object is compared on the views it answered, with pcrp's figure on the same
    views beside it.
    """
    yes = lambda ok: 'yes' if ok else '**no**'   # noqa: E731
    rows = []
    for name in ONE_SIDED:
        if name not in summaries:
            continue
        s = summaries[name]['pcrp']['overall']
        rows.append([f'right object, {_title(name)}', f'>= {_pct(RIGHT_OBJECT)}',
                     f"{_pct1(s['right_object'])} (or its twin {_pct1(s['right_or_twin'])})",
                     yes(s['right_object'] >= RIGHT_OBJECT)])
        rows.append([f'pose right, {_title(name)}', f'>= {_pct(POSE_RIGHT[name])}',
                     _pct1(s['pose_right']), yes(s['pose_right'] >= POSE_RIGHT[name])])
        if 'ransac_told' in summaries[name]:
            told = summaries[name]['ransac_told']['overall']
            ours = statistics(_baseline_views_only(res['results'][name]['pcrp'], res))
            rows.append([f'pose right against Open3D told the object, {_title(name)}',
                         'at least as often, on the views it answered',
                         f"{_pct1(ours['pose_right'])} vs {_pct1(told['pose_right'])} "
                         f"({told['views']} views)",
                         yes(ours['pose_right'] >= told['pose_right'])])
    one = statistics(_pooled(res, 'pcrp', ONE_SIDED))
    rows.append(['wrong but accepted / right but rejected, one-sided',
                 f"<= {_pct(TARGETS['wrong_accepted'])} / <= {_pct(TARGETS['right_rejected'])}",
                 f"{_pct1(one['wrong_accepted'])} / {_pct1(one['right_rejected'])}",
                 yes(one['wrong_accepted'] <= TARGETS['wrong_accepted']
                     and one['right_rejected'] <= TARGETS['right_rejected'])])
    known, unknown, _, _ = _unknown_split(res, ONE_SIDED)
    if unknown:
        rej, auc = _unknown_rejected(unknown, _min_confidence(res)), _unknown_auc(known, unknown)
        rows.append(['objects the gallery lacks: rejected / ROC AUC, one-sided',
                     f">= {_pct(TARGETS['unknown_rejected'])} / >= {TARGETS['unknown_auc']}",
                     f'{_pct1(rej)} / {_num(auc, 3)}',
                     yes(rej >= TARGETS['unknown_rejected'] and auc >= TARGETS['unknown_auc'])])
    return ('What the robot-case and confidence issues ask of one-sided views of known objects '
            f'(free in space; on a table with up known), at the default min_confidence '
            f'{_min_confidence(res)}; speed is judged in BENCHMARKS.md.\n\n'
            + _table(['bar', 'asked', 'measured', 'met'], rows))


def _families(res: dict, summaries: dict) -> str:
    parts = []
    for name, per_method in summaries.items():
        rows = []
        for fam in per_method['pcrp']['families']:
            for method, s in per_method.items():
                st = s['families'].get(fam)
                if st:
                    rows.append([f"{fam} ({st['views']})", res['methods'][method]]
                                + _stat_cells(method, st))
        parts.append(f'#### {_title(name)}\n\n'
                     + _table(['family (views)', 'method'] + STAT_TITLES, rows))
    return '\n\n'.join(parts)


def _confidence_section(res: dict) -> str:
    threshold = _min_confidence(res)
    rows = []
    for name in list(res['results']) + ['one-sided', 'all']:
        names = ONE_SIDED if name == 'one-sided' else None if name == 'all' else (name,)
        pc = _pooled(res, 'pcrp', names)
        s = statistics(pc)
        answered = _answered(pc)
        ece = expected_calibration_error([r['confidence'] for r in answered],
                                         [r['pose_right'] for r in answered])
        title = {'one-sided': '**free + table (one-sided)**', 'all': '**all**'}.get(
            name, _title(name))
        rows.append([title, str(s['views']), _pct(s['pose_right']), _pct(s['accepted']),
                     _pct(s['right_accepted']), _pct(s['wrong_accepted']),
                     _pct(s['right_rejected']), _num(s['confidence_auc']), _num(ece, 3)])
    one = statistics(_pooled(res, 'pcrp', ONE_SIDED))
    verdict = (f'On the one-sided views (free and on a table, unoccluded) the issue asks for '
               f'wrong '
               f"but accepted <= {_pct(TARGETS['wrong_accepted'])} with right but rejected <= "
               f"{_pct(TARGETS['right_rejected'])}: pcrp has {_pct1(one['wrong_accepted'])} and "
               f"{_pct1(one['right_rejected'])} ("
               + ('met' if one['wrong_accepted'] <= TARGETS['wrong_accepted']
                  and one['right_rejected'] <= TARGETS['right_rejected'] else 'not met') + ').')
    answered = _answered(_pooled(res, 'pcrp'))
    bins = reliability([r['confidence'] for r in answered], [r['pose_right'] for r in answered])
    lo = np.linspace(0, 1, 11)
    bin_rows = []
    for c, share, k in bins:
        b = min(int(c * 10), 9)
        bin_rows.append([f'{lo[b]:.1f}-{lo[b + 1]:.1f}', str(k), f'{c:.2f}', f'{share:.2f}'])
    return '\n\n'.join([
        f"pcrp's `confidence` is meant as the probability that the answer is right (the right "
        f"object or its twin, posed within ADD-S 10 %); answers below the model's default "
        f'min_confidence {threshold} are rejected. Right accepted, wrong accepted: shares of the '
        f'views; right rejected: share of the right answers; conf AUC: chance that a right '
        f"answer's confidence beats a wrong one's; ECE: mean gap between confidence and share "
        f'right over 10 bins, weighted by their counts.',
        _table(['scenario', 'views', 'right', 'accepted', 'right accepted', 'wrong accepted',
                'right rejected', 'conf AUC', 'ECE'], rows),
        verdict,
        '**Reliability** (all scenarios pooled, known objects; per scenario in the figure, with '
        "the held-out model's answers on known and unknown objects beside them):",
        _table(['confidence', 'answers', 'mean confidence', 'share right'], bin_rows),
        f"![reliability diagram]({FILES[res['split']]}_reliability.png)\n\n"
        f"![ROC curves of the confidence]({FILES[res['split']]}_roc.png)",
    ])


def _unknown_section(res: dict) -> str:
    ho = res['held_out']
    threshold = _min_confidence(res)
    n_gallery = res['gallery_size'] - len(ho['objects'])
    how = ('built by the same recipe from the other meshes (a folder of links to them), so its '
           'calibration and twins are its own' if ho['how'] == 'rebuilt' else
           "**in this quick run, the full model's gallery less them (PCRP.subset): its "
           'calibration saw them**')
    near = ho['lookalikes']
    text = [
        f"{len(ho['objects'])} objects held out, drawn by a permutation of the gallery seeded "
        f"with {ho['seed']} (fixed in tools/robot_protocol.py before any view was answered), each "
        f'with the objects the full model records as its twins: '
        + ', '.join(f'`{g}`' for g in ho['objects'])
        + f'. The second model has the other {n_gallery} objects, {how}; it answers every view '
        f'of every scenario. Its answers on the held-out objects are all wrong, whatever they '
        f'name: a robot should reject them. Right vs unknown: the ROC AUC of the confidence, '
        f'its right answers on the objects it holds against its answers on the held-out ones. '
        f'Rejected and accepted at min_confidence {threshold}.',
    ]
    rows = []
    for name in list(res['unknown']) + ['one-sided', 'all']:
        names = ONE_SIDED if name == 'one-sided' else None if name == 'all' else (name,)
        known, *parts = _unknown_split(res, names)
        s = statistics(known)
        title = {'one-sided': '**free + table (one-sided)**', 'all': '**all**'}.get(
            name, _title(name))
        rows.append([title, str(len(parts[0]))]
                    + [_pct(_unknown_rejected(p, threshold)) for p in parts]
                    + [_num(_unknown_auc(known, p)) for p in parts]
                    + [_pct(s['pose_right']), _pct(s['wrong_accepted']),
                       _pct(s['right_rejected'])])
    text.append(_table(['scenario', 'unknown views', 'unknown rejected',
                        'with a look-alike left: rejected', 'without: rejected',
                        'right vs unknown AUC', 'with a look-alike: AUC', 'without: AUC',
                        'known: right', 'known: wrong acc', 'known: right rej'], rows))
    unknown = _unknown_split(res, None)[1]
    known_one, unknown_one, _, _ = _unknown_split(res, ONE_SIDED)
    rej, auc = _unknown_rejected(unknown_one, threshold), _unknown_auc(known_one, unknown_one)
    text.append(
        f"The issue asks for >= {_pct(TARGETS['unknown_rejected'])} of objects from outside the "
        f"gallery rejected and a ROC AUC right-versus-outside >= {TARGETS['unknown_auc']}: on the "
        f"one-sided views the held-out model rejects {_pct1(rej)} of the unknown objects' views "
        f"({'met' if rej >= TARGETS['unknown_rejected'] else 'not met'}) with AUC {_num(auc, 3)} "
        f"({'met' if auc >= TARGETS['unknown_auc'] else 'not met'}).")
    if near:
        text.append('Held-out objects with a look-alike left in the gallery (chamfer below '
                    f"{res['twins']['within'] * 1000:.0f} mm in the twin table below): "
                    + '; '.join(f"`{g}` ({', '.join(f'`{o}`' for o in others)})"
                                for g, others in near.items())
                    + '. Their views are nearly those of a known object: what the gallery '
                    'holds explains them within the noise.')
    else:
        text.append('No held-out object has a look-alike (chamfer below '
                    f"{res['twins']['within'] * 1000:.0f} mm) left in the gallery.")
    accepted = [r for r in unknown if r['gallery_id'] is not None
                and r['confidence'] >= threshold]
    counts: dict = {}
    for r in accepted:
        counts[(r['object_id'], r['gallery_id'])] = counts.get((r['object_id'],
                                                                r['gallery_id']), 0) + 1
    top = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))[:12]
    if top:
        text.append(f'**Unknown objects accepted** ({len(accepted)} of {len(unknown)} views, all '
                    'scenarios), most frequent first:\n\n'
                    + _table(['held-out object', 'accepted as', 'views', 'look-alike'],
                             [[a, b, str(n), 'yes' if b in near.get(a, ()) else '']
                              for (a, b), n in top]))
    return '\n\n'.join(text)


def _sweep(res: dict) -> str:
    rows = []
    for name in list(res['results']) + ['one-sided', 'all']:
        names = ONE_SIDED if name == 'one-sided' else None if name == 'all' else (name,)
        pc = _pooled(res, 'pcrp', names)
        unknown = _unknown_split(res, names)[1]
        title = {'one-sided': '**free + table**', 'all': '**all**'}.get(name, _title(name))
        for t in THRESHOLDS:
            s = statistics(pc, t)
            rows.append([title, f'{t:.1f}', _pct(s['right_accepted']), _pct(s['wrong_accepted']),
                         _pct(s['right_rejected']), _pct(_unknown_rejected(unknown, t))])
    return ('What each min_confidence would do on these views (the model rejects exactly the '
            'answers whose confidence is below it, so every threshold is read off the same '
            "answers). Right accepted, wrong accepted: shares of the known objects' views (full "
            'model); right rejected: share of its right answers; unknown rejected: share of the '
            "held-out objects' views the held-out model rejects. The default is chosen here, on "
            'validation views, never on the test views.\n\n'
            + _table(['scenario', 'min_confidence', 'right accepted', 'wrong accepted',
                      'right rejected', 'unknown rejected'], rows))


def _stages(res: dict, summaries: dict) -> str:
    keys = list(dict.fromkeys(k for per in summaries.values() for k in per['pcrp']['stages']))
    if 'total' in keys:     # last, after stages only some views ran
        keys = [k for k in keys if k != 'total'] + ['total']
    rows = []
    for name, per in summaries.items():
        st = per['pcrp']['stages']
        s = per['pcrp']['overall']
        views = res['results'][name]['pcrp']
        cells = []
        for k in keys:
            ran = sum(k in (v.get('timings') or {}) for v in views)
            cells.append(_num(st.get(k, float('nan')) * 1000, 1)
                         + (f' ({ran} of {len(views)})' if 0 < ran < len(views) else ''))
        rows.append([_title(name)] + cells
                    + [_num(s['seconds_median'] * 1000, 0), _num(s['seconds_p95'] * 1000, 0)])
    return ("pcrp's seconds per view on one core (OMP/BLAS threads 1), wall time of "
            '`model.estimate`; per stage, the mean of `result.timings` (milliseconds; total '
            "is the model's own count, the median and p95 are the caller's). A stage that only "
            'some views run (local_shape: answers that fit poorly) is the mean over those, with '
            'how many:\n\n'
            + _table(['scenario'] + keys + ['median', 'p95'], rows))


def _looking_again(res: dict, summaries: dict) -> str | None:
    """Set the partly hidden views answered with and without looking again side by side."""
    names = [n for n, per in summaries.items() if 'pcrp_no_local_shape' in per]
    if not names:
        return None
    rows = []
    for name in names:
        for method in ('pcrp', 'pcrp_no_local_shape'):
            s = summaries[name][method]['overall']
            ran = sum('local_shape' in (v.get('timings') or {})
                      for v in res['results'][name][method])
            rows.append([_title(name),
                         'defaults' if method == 'pcrp' else 'local_shape_cost .inf',
                         f"{ran} of {s['views']}", _pct(s['pose_right']),
                         _pct(s['right_accepted']), _pct(s['wrong_accepted']),
                         _pct(s['right_rejected']), _num(s['seconds_median'] * 1000, 0),
                         _num(s['seconds_p95'] * 1000, 0)])
    return ('An answer that fits poorly (or, given the scene, is partly hidden) is looked for '
            'again: a few more poses of the best objects, then, if it still fits poorly, matched '
            "local shape, FPFH in RANSAC on the objects of the cloud's shape (the node's "
            '`local_shape_cost` and `local_shape_cost_hidden`). A user who needs speed over '
            'partly hidden objects more than the objects it finds sets both to `.inf`: the same '
            'views answered so, beside the defaults. Looked again: views local shape ran on; '
            'right accepted and wrong accepted: shares of the views; right rejected: share of '
            'the right answers; times in ms, one thread.\n\n'
            + _table(['scenario', 'settings', 'looked again', 'pose right', 'right accepted',
                      'wrong accepted', 'right rejected', 'median ms', 'p95 ms'], rows))


def _family_matrix(res: dict, summaries: dict) -> str:
    names = list(summaries)
    have = 'ransac' in summaries[names[0]]
    rows = []
    for fam in summaries[names[0]]['pcrp']['families']:
        cells = []
        for n in names:
            p = summaries[n]['pcrp']['families'][fam]['pose_right']
            r = (summaries[n]['ransac']['families'].get(fam, {}).get('pose_right')
                 if 'ransac' in summaries[n] else None)
            cells.append(_pct(p) + (f' / {_pct(r)}' if have else ''))
        rows.append([fam] + cells)
    return _table(['family'] + [_title(n) for n in names], rows)


def _by_size(res: dict) -> str:
    methods = [m for m in ('pcrp', 'ransac') if m in res['methods']]
    rows = []
    for lo, hi, label in SIZE_BINS:
        cells = []
        for method in methods:
            sel = [r for r in _pooled(res, method) if lo <= r['diameter'] < hi]
            cells += [_pct(np.mean([r['right_or_twin'] for r in sel])) if sel else '-',
                      _pct(np.mean([r['pose_right'] for r in sel])) if sel else '-']
        n = len([r for r in _pooled(res, 'pcrp') if lo <= r['diameter'] < hi])
        rows.append([label, str(n)] + cells)
    header = ['object diameter', 'views (pcrp)']
    for m in methods:
        header += [f'{m}: object or twin', f'{m}: pose right']
    return _table(header, rows)


def _chamfer_pairs(res: dict) -> set:
    return {frozenset(p[:2]) for p in res['twins']['pairs']}


def _confusions(res: dict, method: str, top: int = 12) -> tuple[str, float, int]:
    model_twins = {frozenset(p) for p in res['model']['twins']}
    near = _chamfer_pairs(res)
    wrong = [r for r in _pooled(res, method) if r['gallery_id'] is not None
             and not r['right_object']]
    counts: dict = {}
    for r in wrong:
        counts[(r['object_id'], r['gallery_id'])] = counts.get((r['object_id'],
                                                                r['gallery_id']), 0) + 1
    ranked = sorted(counts.items(), key=lambda kv: (-kv[1], kv[0]))[:top]
    rows = [[a, b, str(n), 'model twin' if frozenset((a, b)) in model_twins
             else 'within 2 mm' if frozenset((a, b)) in near else ''] for (a, b), n in ranked]
    share = float(np.mean([frozenset((r['object_id'], r['gallery_id'])) in near | model_twins
                           for r in wrong])) if wrong else 0.0
    return _table(['object shown', 'answered', 'views', 'same shape'], rows), share, len(wrong)


def _retrieval(res: dict) -> str:
    rows = []
    for name, per in res['results'].items():
        ranks = [r['candidate_rank'] for r in per['pcrp'] if r.get('candidate_rank') is not None]
        if not ranks:
            return ''
        listed = [r for r in per['pcrp'] if r.get('candidate_rank')]
        rows.append([_title(name), _pct(np.mean([k > 0 for k in ranks])),
                     _pct(np.mean([r['right_object'] for r in listed])) if listed else '-'])
    return ('**Shortlist or choice?** How often the object shown was among the objects pcrp '
            'refined and verified (its candidates), and how often pcrp chose it when it was:\n\n'
            + _table(['scenario', 'among the verified', 'chosen when among them'], rows))


def _analysis(res: dict, summaries: dict) -> str:
    pc = _pooled(res, 'pcrp')
    s_pc = statistics(pc)
    out = []
    line = (f'Over all {len(pc)} views pcrp names the right object in '
            f"{_pct(s_pc['right_object'])} (or its twin in {_pct(s_pc['right_or_twin'])}) and "
            f"poses it right in {_pct(s_pc['pose_right'])}, in {s_pc['seconds_median']:.2f} s "
            f"(median; p95 {s_pc['seconds_p95']:.2f} s).")
    if 'ransac' in res['methods']:
        rs, rt = _pooled(res, 'ransac'), _pooled(res, 'ransac_told')
        s_rs, s_rt = statistics(rs), statistics(rt)
        s_same = statistics(_baseline_views_only(pc, res))
        line += (f' On the {len(rs)} views Open3D answered, pcrp poses '
                 f"{_pct(s_same['pose_right'])} "
                 f'right; FPFH + RANSAC + ICP registering each view to every size-compatible '
                 f"object and keeping the best fit {_pct(s_rs['pose_right'])} "
                 f"({s_rs['seconds_median']:.2f} s median, p95 {s_rs['seconds_p95']:.2f} s), and "
                 f"told the object {_pct(s_rt['pose_right'])}.")
        out.append(line)
        out.append('**Pose right by family and scenario, pcrp / FPFH + RANSAC + ICP with own '
                   'retrieval:**\n\n' + _family_matrix(res, summaries))
    else:
        out.append(line)
    out.append('**By object size** (all scenarios pooled):\n\n' + _by_size(res))
    retrieval = _retrieval(res)
    if retrieval:
        out.append(retrieval)
    table, share, n_wrong = _confusions(res, 'pcrp')
    text = (f"**pcrp's most frequent confusions** (all scenarios; {n_wrong} answers named "
            f'another object, {_pct(share)} of them one of the same shape: a twin the model '
            f'records or within 2 mm in the chamfer table')
    if 'ransac' in res['methods']:
        _, rs_share, rs_wrong = _confusions(res, 'ransac')
        text += f", against {_pct(rs_share)} of RANSAC's {rs_wrong}"
    out.append(text + '):\n\n' + table)
    right = [r for r in pc if r['right_or_twin']]
    off = [r for r in right if not r['pose_right']]
    flips = [r for r in off if r['rotation_error_deg'] is not None
             and r['rotation_error_deg'] > 150]
    rot = [r['rotation_error_deg'] for r in off if r['rotation_error_deg'] is not None]
    out.append(f"**Right object, pose off:** {len(off)} of pcrp's {len(right)} answers naming "
               f'the object or its twin put its surface beyond 10 % of the diameter; {len(flips)} '
               f'of those are turned more than 150° (a flip onto a near-symmetric pose)'
               + (f', median rotation error of the off ones {np.median(rot):.0f}°.' if rot
                  else '.'))
    never = sorted({r['object_id'] for r in pc} - {r['object_id'] for r in pc if r['pose_right']})
    out.append(f'**Objects pcrp never posed right** in any of their views ({len(never)} of '
               f"{len({r['object_id'] for r in pc})}): "
               + (', '.join(f'`{k}`' for k in never) if never else 'none') + '.')
    return '\n\n'.join(out)


def _twins(res: dict) -> str:
    tw = res['twins']
    rows = [[f'`{a}`', f'`{b}`', f'{c * 1000:.2f}'] for a, b, c in tw['pairs']]
    near = [[f'`{a}`', f'`{b}`', f'{c * 1000:.2f}'] for a, b, c in tw['nearest_others']]
    model = res['model']['twins']
    text = ('**Twins the model records** (found at build time: each, left out of the gallery, '
            'is answered as the other about as well as itself; an answer naming one for the '
            'other counts as right object or twin, and as pose right when it puts the surface '
            'in place): ' + ('; '.join(f'`{a}` and `{b}`' for a, b in model) if model else 'none')
            + '.\n\n'
            f'**Chamfer table** (tools/robot_twins.py): pairs whose shapes coincide within '
            f"{tw['within'] * 1000:.0f} mm: symmetric chamfer (mean of the two one-way mean "
            f"distances from one's surface points to the other's surface) after the best rigid "
            f"alignment of one onto the other ({tw['pairs_aligned']} pairs of similar diameter "
            f'and principal spreads aligned). It decides which held-out objects have a look-alike '
            f'left in the gallery, and marks confusions.\n\n')
    text += _table(['object', 'twin', 'chamfer (mm)'], rows) if rows else 'None.'
    if near:
        text += ('\n\nThe nearest pairs beyond that, for context:\n\n'
                 + _table(['object', 'other', 'chamfer (mm)'], near))
    return text


def _header(res: dict) -> list[str]:
    n_obj = len(res['objects'])
    views = res['views_per_object']
    m = res['machine']
    load = res.get('load', [float('nan')] * 2)
    command = ' '.join(['python -m tools robot-report --data <ycb> --out docs/results']
                       + (['--quick'] if res['quick'] else [])
                       + ([f'--views-per-object {views}'] if views != VIEWS_PER_OBJECT
                          and not res['quick'] else [])
                       + ([f"--baseline-views {res['baseline_views']}"]
                          if 0 < res['baseline_views'] < views else [])
                       + (['--no-baselines'] if res['baseline_views'] == 0 else [])
                       + ([f"--split {res['split']}"] if res['split'] != 'test' else []))
    banner = ''
    if res['quick']:
        banner += '**QUICK RUN (smoke test): a few objects, one view each; not the report.**\n'
    if res['split'] == 'validation':
        banner += (f"**Validation views (seed {res['seed']}): for choosing settings; the "
                   "reported figures are the test views' (ROBOT.md).**\n")
    base = res['baseline_views']
    if base == 0:
        scope = 'pcrp only (no Open3D baselines in this run). '
    elif base < views:
        scope = (f"Open3D's pipelines answer the first {base} view(s) of each object and "
                 f'scenario ({n_obj * base} per scenario): at about 4 s a view with their own '
                 f'retrieval, all {n_obj * views * 4} views would take the run past an hour on '
                 f"this shared machine; pcrp's figures beside theirs are given on the same views "
                 f'too. ')
    else:
        scope = 'Every method answers every view. '
    return [
        "# pcrp on the YCB objects, as a robot's depth camera sees them",
        '',
        banner
        + f"Generated by `{command}` in {res['seconds']['total'] / 60:.0f} minutes on "
        f"{m['cores']} cores ({m['cpu']}, one thread; load average {load[0]:.1f} at the start "
        f'and {load[1]:.1f} at the end: the machine was '
        + ('shared with other work, which lengthens the times' if _shared(load, m['cores'])
           else 'otherwise idle')
        + f"), {m['date']}. {n_obj} of the {res['gallery_size']} objects, {views} view(s) each "
        f'per scenario: {n_obj * views} views per scenario, {4 * n_obj * views} in all. '
        + scope + f"Per-view records: [{FILES[res['split']]}.json]({FILES[res['split']]}.json).",
    ]


def _shared(load: list, cores: int) -> bool:
    """
    Tell whether other work competed for the cores during a run, from its load averages.

    The run's own work keeps the load near 1.5 at its end on 2 cores, so only a busy start or an
    end above the cores says so.
    """
    return load[0] > cores / 2 or load[1] > cores


def _views_and_methods(res: dict) -> list[str]:
    cam, noise = PinholeCamera(), RangeNoise()
    hfov = 2 * math.degrees(math.atan(cam.width / 2 / cam.fx))
    b = res['baselines']
    mdl = res['model']
    lines = [
        '## The views',
        '',
        f'- Camera: pinhole {cam.width} x {cam.height}, fx = fy = {cam.fx:.0f}, centre '
        f'({cam.cx}, {cam.cy}) ({hfov:.0f}° horizontal field of view); clouds in the optical '
        f'frame (x right, y down, z forward), metres; rays cast on the meshes with Open3D '
        f'(pcrp_core.sources.camera).',
        f'- Range noise: Gaussian along each ray, sigma(z) = {noise.base * 1000:.1f} mm + '
        f'{noise.quadratic} z² ({noise.sigma(DISTANCE[0]) * 1000:.1f} mm at {DISTANCE[0]} m, '
        f'{noise.sigma(DISTANCE[1]) * 1000:.1f} mm at {DISTANCE[1]} m).',
        f"- Perfect segmentation: the cloud is exactly the object's visible pixels; at least "
        f'{MIN_PIXELS} of them (poses are redrawn otherwise).',
        f"- Free: uniform random rotation, the object's centre {DISTANCE[0]}-{DISTANCE[1]} m "
        f'from the camera along a ray through the central half of the image.',
        f'- On a table: the object upright as modelled (z up) on its lowest point, random turn '
        f'about the vertical, camera {DISTANCE[0]}-{DISTANCE[1]} m away looking down at '
        f"{ELEVATION_DEG[0]:.0f}-{ELEVATION_DEG[1]:.0f}° without roll, panned so the object's "
        f'centre falls in the central half of the image. The table is not in the cloud. pcrp is '
        f"given the table's normal as up (the node's up_vector); the Open3D pipelines have no "
        f'such input.',
        f'- Occluded: a random box or cylinder between the camera and the object hides '
        f"{100 * OCCLUDED_SHARE[0]:.0f}-{100 * OCCLUDED_SHARE[1]:.0f} % of the object's pixels; "
        f"the cloud is the object's pixels left visible. An occluded view keeps the pose of its "
        f'unoccluded counterpart whenever that pose leaves enough pixels.',
        '- Occluder seen: the same occluded views, pcrp given what the camera measured of the '
        "occluder (with the object's own pixels) as the scene, as the node's scene_topics give "
        "it a camera's whole depth cloud: surface the occluder hides is then not counted "
        'missing. Pooled figures ("all") count each view once, without these.',
        f'- Seeds: every view is drawn from its own generator seeded by (split seed, object '
        f'index, view index). Test views: seed {SEEDS["test"]} (ROBOT.md). Validation views: '
        f'seed {SEEDS["validation"]} (`--split validation`, ROBOT_validation.md). pcrp learns its '
        f'confidence at build time on views of its own meshes drawn with seed {CALIBRATION_SEED} '
        f'(never a '
        f"report's). **The test views were never used to choose anything**: pcrp runs with its "
        f"defaults (min_confidence {_min_confidence(res)} is the package's default; the sweep "
        f'a default is to be chosen on is on validation views, in ROBOT_validation.md), the '
        f"Open3D settings are the tutorial's or were chosen on validation views (below), and "
        f'the held-out objects were drawn with a '
        f'fixed seed before any view was answered.',
        '',
        '## The methods',
        '',
        f'- **pcrp**: the model built as the README tells a user with a depth camera, '
        f"`{mdl['recipe']}` (camera templates are made from the meshes; `--up-axis z` lets a "
        f"query state up), code {mdl['code']}, {mdl['n_objects']} objects"
        + (f", templates {mdl['templates']['views']} views" if mdl.get('templates') else '')
        + '; answered with its defaults ('
        + ', '.join(f'{k} {v}' for k, v in mdl['options'].items())
        + ') as the node calls it: the sensor at the origin (viewpoint), up in the table '
        "scenarios. Confidence: the answer's `confidence`, calibrated at build time"
        + ('' if mdl.get('calibrated', True) else ' (**this model has no calibration**)') + '.',
    ]
    if res['baseline_views']:
        cands = np.mean([g['candidates_mean'] for g in res['gate'].values()])
        lines += [
            f'- **Open3D FPFH + RANSAC + ICP / FPFH + FGR + ICP** (tools/robot_open3d.py), as '
            f"Open3D's global registration tutorial sets them up at a {b['voxel'] * 1000:.0f} mm "
            f"voxel: normals from {b['normal_radius'] * 1000:.0f} mm (the view's towards the "
            f"camera, the model's from its outward triangle normals), FPFH from "
            f"{b['feature_radius'] * 1000:.0f} mm, RANSAC within "
            f"{b['ransac_distance'] * 1000:.1f} mm ({b['ransac_criteria'][0]:,} iterations, "
            f"confidence {b['ransac_criteria'][1]}, mutual filter, edge-length and distance "
            f"checkers), FGR within {b['fgr_distance'] * 1000:.1f} mm, then point-to-plane ICP "
            f"within {b['icp_distance'] * 1000:.1f} mm. The view is registered onto the whole "
            f'surface of the model.',
            '  - *told the object*: registered onto the true object only (a task pcrp is not '
            'given: it must also find the object among all of them).',
            f'  - *own retrieval*: registered onto every gallery object whose diameter is '
            f"between {1 / b['gate'][1]:.2f} and {1 / b['gate'][0]:.0f} times the view's extent "
            f"(registering onto all {res['gallery_size']} would take about "
            f"{res['gallery_size'] / max(cands, 1):.1f}x longer), keeping the best ICP fitness "
            f'(in 1 % steps), then the lowest inlier RMSE. '
            + '; '.join(f"{_title(k)}: {g['candidates_mean']:.0f} candidates on average, true "
                        f"object dropped by the gate in {g['true_dropped']} of {g['views']} views"
                        for k, g in res['gate'].items())
            + '. They never reject; their confidence is the ICP fitness. Their times include the '
            "view's features and every registration, not the models' features (computed once, "
            "as pcrp's model is).",
            '',
            'Chosen on validation views (seed 1000) while writing the harness:',
            '',
            *[f'- {c}.' for c in CHOICES],
        ]
    return lines


def markdown(res: dict, summaries: dict) -> str:
    stem = FILES[res['split']]
    m = res['machine']
    lines = _header(res) + [
        '',
        '## Headline',
        '',
        _headline(res, summaries),
        '',
        '## The bar',
        '',
        _bar(res, summaries),
        '',
        '## Overall',
        '',
        'Right obj: the answer names the object shown. Obj or twin: or an object the model '
        'records as its twin (the same shape: no depth camera tells them apart). Pose right: '
        'either, with ADD-S below 10 % of the diameter (for a twin: the mean distance from the '
        "shown object's posed surface to the answer's). ADD-S AUC: YCB-Video's area under the "
        'share-of-views-below-threshold curve, 0-10 cm, of the same distance (another object or '
        'no answer fails at every threshold). Rotation and translation medians: over the answers '
        'naming the right object; rotation is the geodesic angle, blind to symmetry, translation '
        "how far the object's centre is put. Accepted, wrong acc (accepted and not right): "
        "shares of the views, at the model's default min_confidence "
        f'{_min_confidence(res)}; right rej: share of the right answers rejected; conf AUC: '
        "chance that a right answer's confidence beats a wrong one's. Time: wall time per view "
        'on one thread.',
        '',
        _overall(res, summaries),
        '',
        f'![share of views with ADD-S below a threshold]({stem}_adds.png)',
        '',
        '## Confidence',
        '',
        _confidence_section(res),
        '',
        '## Objects the gallery does not hold',
        '',
        _unknown_section(res),
        '',
    ]
    if res['split'] == 'validation':
        lines += ['## Threshold sweep', '', _sweep(res), '']
    lines += [
        '## Time',
        '',
        _stages(res, summaries),
        '',
    ]
    again = _looking_again(res, summaries)
    if again:
        lines += ['### Looking again: what it buys and what it costs', '', again, '']
    lines += [
        '## Where pcrp fails',
        '',
        _analysis(res, summaries),
        '',
        '## Per family',
        '',
        'YCB families by id: food 002-019, kitchen 021-033, tools 035-052, balls 053-058, '
        'shape/task 059-077.',
        '',
        _families(res, summaries),
        '',
        *_views_and_methods(res),
        '',
        '## Geometric twins',
        '',
        _twins(res),
        '',
        '## Run',
        '',
        'Seconds per part: ' + '; '.join(
            f'{k} ' + (', '.join(f'{kk} {vv:.0f}' for kk, vv in v.items())
                       if isinstance(v, dict) else f'{v:.0f}')
            for k, v in res['seconds'].items()) + '. Versions: '
        + ', '.join(f'{k} {v}' for k, v in m['versions'].items() if v != '-') + '.',
        '',
        '## Credit',
        '',
        'Meshes: the YCB Object and Model Set (B. Calli, A. Walsman, A. Singh, S. Srinivasa, P. '
        'Abbeel, A. M. Dollar, "The YCB object and model set: towards common benchmarks for '
        'manipulation research", ICAR 2015; Calli et al., IEEE Robotics & Automation Magazine '
        '2015), used under the Creative Commons Attribution 4.0 International license (CC BY '
        '4.0). The meshes are not part of this repository.',
        '',
    ]
    return '\n'.join(lines)


def write(res: dict, out: Path) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    stem = FILES[res['split']]
    summaries = {name: {m: summarise(rows) for m, rows in per.items()}
                 for name, per in res['results'].items()}
    (out / f'{stem}.json').write_text(json.dumps(jsonable({**res, 'summaries': summaries}, 6),
                                                 separators=(',', ':')))
    plot_adds(res, out / f'{stem}_adds.png')
    plot_reliability(res, out / f'{stem}_reliability.png')
    plot_roc(res, out / f'{stem}_roc.png')
    md = 'ROBOT.md' if res['split'] == 'test' else 'ROBOT_validation.md'
    (out / md).write_text(markdown(res, summaries))
    return out / md
