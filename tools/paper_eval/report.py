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

"""RESULTS.md: every table with the paper's figures beside ours, the CDF plot, example pictures."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from tools.paper_eval import frames, pose_table, registration_table, retrieval_table
from tools.paper_eval.metrics import geodesic_deg, LABEL_TOLERANT
from tools.paper_eval.protocol import (INSTANCE_NOISE, PAPER_CATEGORIES, PLANE_KEEP, VIEW_NOISE,
                                       VIEWS)

# The paper's figures (Kadam, Zhou, Liu, Kuo), as the issue quotes them.
PAPER_REGISTRATION = {'rotation': {'mse': 2.68, 'rmse': 1.64, 'mae': 0.33},
                      'translation': {'mse': 0.0002, 'rmse': 0.0149, 'mae': 0.0007}}
PAPER_RETRIEVAL = {'aligned': {'pcrp_vlad': (63.23, 0.101), 'fpfh_vlad': (53.23, 0.164)},
                   'arbitrary': {'pcrp_vlad': (63.07, 0.111), 'fpfh_vlad': (52.12, 0.160)}}
PAPER_POSE = {
    'chair': (14.42, 4.24),
    'airplane': (2.98, 1.65),
    'car': (11.22, 2.11),
    'sofa': (8.84, 2.29),
}
CHEN_POSE = {
    'chair': (8.56, 3.87),
    'airplane': (3.35, 1.12),
    'car': (9.48, 1.85),
    'sofa': (4.76, 1.56),
}
RATIO = 63.23 / 53.23
CLASSICAL = ('icp', 'fgr_icp', 'ransac_icp')
LABELS_NOTE = (
    'Labels either way: the error to the nearest of the truth turned a quarter, half or three '
    'quarters about the up axis, for the categories whose labels lay the horizontal axes either '
    f"way ({', '.join(LABEL_TOLERANT)}; see the notes); over all, with those and the others' own "
    'errors.'
)
# laid out as it lands in RESULTS.md, so its lines are left as they are
NOTES = """\
- **This copy of ModelNet40 is not consistently aligned for cars and airplanes.** A car's length
  lies along x for some training and test cars and along y for the others ("What the data allows"
  counts them); airplanes are turned against each other too. Any method that reads a pose off a
  *different* gallery instance inherits that quarter turn whenever the query and the retrieved
  object disagree, so car and airplane means carry errors no registration can remove (most of their
  large errors lie at 80–100°). The share under 5° and the median say more there, and the
  known-objects table shows the registration itself when the labels cannot disagree.
- **Chairs and sofas are nearly symmetric front to back.** The remaining large errors are mostly
  half turns (about 180°) of the right pose: flat sofas upside down, lounge chairs whose seat and
  back swap places. The candidate vote (16 retrieved objects), the half-turn hypotheses and, for
  whole clouds, the reverse fit (the posed gallery object's points must be near the cloud too,
  untrimmed: a chair turned back to front puts its legs where no leg is) are what this package
  adds against them.
- **Retrieval gains less over FPFH + VLAD than the paper reports** (1.1× here, 1.19× there). FR-PointHop's
  first hop *is* FPFH, and its second hop pools those same histograms over octants, so on 1024-point
  objects the two descriptors rank the gallery much alike; the paper does not define its Precision@10
  or its chamfer distance, and under both definitions measured here the gap is the same. Retrieval
  still matters for pose: the candidates it returns are what the vote registers.
- **The paper's numbers used 2048 points** and do not say which range of rotations its ICP and FGR
  rows used; under uniform rotations the classical pipelines are far worse than the paper's table,
  under the narrower protocol (each Euler angle in [0°, 45°]) much closer to it.
- **Rejection works on known objects, much less across instances.** The confidence is learnt from
  how well the retrieved object, posed, explains the cloud and how far ahead of the others it is.
  When the gallery holds the object itself (the robot's case) a right answer fits almost perfectly
  and a wrong one does not, so most rejected clouds are ones that would have been wrong. When the
  gallery holds only relatives (the category-level tables), a right pose on a different instance
  fits less well: whole clouds keep most right answers (airplanes and cars read with their labels
  either way, as the confidence is learnt), but a one-sided view of a relative fits so much worse
  that many right answers are refused with the wrong ones; most objects from other categories are
  refused either way (the rejection and confidence tables). `min_confidence` moves the trade
  either way."""  # noqa: E501


def _f(x, nd=2):
    return '–' if x is None or (isinstance(x, float) and np.isnan(x)) else f'{x:.{nd}f}'


def _g(x):
    """
    Three significant figures.

    Registration errors span from 1e-12 (exact) to tens of degrees.
    """
    return '–' if x is None or np.isnan(x) else ('0' if x == 0 else f'{x:.3g}')


def _pct(x):
    return '–' if x is None or x != x else f'{100 * x:.0f} %'


def registration_md(reg: dict) -> list[str]:
    lines = []
    for cut, title in (
        ('full', 'Full objects'),
        (
            'partial',
            f'Partial objects ({int(PLANE_KEEP * 100)} % of the '
            'points, on one side of a random plane)',
        ),
    ):
        if cut not in reg:
            continue
        lines += [
            f'**{title}**',
            '',
            '| method | rotation MSE | RMSE | MAE (°) | translation MSE | RMSE | MAE | median ms '
            '|',
            '|---|---|---|---|---|---|---|---|',
        ]
        for m, d in reg[cut].items():
            r, t = d['rotation'], d['translation']
            lines.append(
                f"| {registration_table.METHODS[m]} | {_g(r['mse'])} | {_g(r['rmse'])} | "
                f"{_g(r['mae'])} | "
                f"{_g(t['mse'])} | {_g(t['rmse'])} | {_g(t['mae'])} | {d['median_ms']:.0f} |"
            )
        if cut == 'full':
            r, t = PAPER_REGISTRATION['rotation'], PAPER_REGISTRATION['translation']
            lines.append(
                f"| *paper: FR-PointHop* | *{r['mse']}* | *{r['rmse']}* | *{r['mae']}* | "
                f"*{t['mse']}* | *{t['rmse']}* | *{t['mae']}* | |"
            )
        lines.append('')
    return lines


def retrieval_md(ret: dict) -> list[str]:
    lines = [
        '| setting | method | P@10 strict | P@10 CORSAIR | top-1 chamfer | paper P@10 / chamfer |',
        '|---|---|---|---|---|---|',
    ]
    for setting in ('aligned', 'arbitrary'):
        if setting not in ret:
            continue
        d = ret[setting]
        for m in retrieval_table.METHODS:
            paper = PAPER_RETRIEVAL[setting].get(m)
            lines.append(
                f"| {setting} | {retrieval_table.METHODS[m]} | {_pct(d[m]['p10_strict'])} | "
                f"{_pct(d[m]['p10_corsair'])} | {d[m]['top1_chamfer']:.3f} | "
                f"{f'{paper[0]} % / {paper[1]}' if paper else ''} |"
            )
        lines.append(f"| {setting} | *the gallery's true nearest / a random pick* | | | "
                     f"*{d['best_top1_chamfer']:.3f} / {d['random_top1_chamfer']:.3f}* | |")
    return lines + ['']


def _either(summary: dict, category: str) -> str:
    """Return the 'labels either way' cell of a pose table's row: mean / median / < 10°."""
    t = summary.get('tolerant') if category in LABEL_TOLERANT + ('all',) else None
    return f"{t['mean']:.2f} / {t['median']:.2f} / {_pct(t['under_10'])}" if t else ''


def rejection_md(rj: dict) -> list[str]:
    """
    Return the rejection section: what the default threshold does with each kind of query.

    Beside the raw figures, those with airplane and car errors taken up to their labels.
    """
    threshold = rj['min_confidence']
    t = rj.get('tolerant', {})

    def row(label: str, key: str) -> str:
        return f"| {label} | {_pct(rj[key])} | {_pct(t[key]) if key in t else ''} |"
    return [
        '## Rejection: objects the gallery does not hold',
        '',
        f'The four-category gallery, default threshold (confidence below {threshold} is '
        f"rejected). Queries of the four categories ({rj['inside_n']}) and of "
        f"{', '.join(rj['outside'])} ({sum(v['n'] for v in rj['outside'].values())}), uniform "
        'rotations. An answer is right when its category is and its rotation error is under '
        f'{pose_table.RIGHT_DEG:.0f}°; labels either way: airplane and car errors up to their '
        'labels, as in the pose tables.',
        '',
        '| queries | measured | labels either way |',
        '|---|---|---|',
        *[
            f"| {c} (not in the gallery) | {_pct(v['rejected'])} rejected | |"
            for c, v in rj['outside'].items()
        ],
        f"| gallery categories: rejected | {_pct(rj['inside_rejected'])} | |",
        row('gallery categories: right but rejected (of all)', 'inside_right_but_rejected'),
        row('gallery categories: wrong and rejected (of all)', 'inside_wrong_and_rejected'),
        row('gallery categories: wrong but accepted (of all)', 'inside_wrong_but_accepted'),
        row('gallery categories: right among accepted', 'inside_right_among_accepted'),
        '',
    ]


def _draws(res: dict, category: str) -> list[dict]:
    """Return PCRP's pose summaries of a category under uniform rotations, one per draw."""
    first = res.get('pose', {}).get('uniform', {}).get('summary', {})
    summaries = [first] + [v for _, v in sorted(res.get('seeds', {}).items())]
    return [d[category]['pcrp'] for d in summaries if 'pcrp' in d.get(category, {})]


def _mean_over(draws: list[dict], category: str) -> tuple[float, float | None]:
    """Return the mean of the draws' means, and of their means with labels either way (or None)."""
    tolerant = [d.get('tolerant') for d in draws] if category in LABEL_TOLERANT else [None]
    return (float(np.mean([d['mean'] for d in draws])),
            float(np.mean([t['mean'] for t in tolerant])) if all(tolerant) else None)


def seeds_md(res: dict) -> list[str]:
    """Return the table of PCRP's pose errors under other draws of the rotations (_draws)."""
    seeds = [str(res['seed'])] + sorted(res['seeds'])
    lines = [
        '### The same objects under other draws of the rotations',
        '',
        "PCRP's defaults on the pose table's queries with the rotations drawn again (`--seed` "
        f"{', '.join(seeds[1:])}): a category's mean moves by several degrees with "
        'a handful of half turns. Mean / median °; airplane and car with their labels either way '
        'in brackets.',
        '',
        '| category | ' + ' | '.join(f'seed {k}' for k in seeds)
        + ' | mean over the draws | paper |',
        '|---' * (len(seeds) + 3) + '|',
    ]
    for cat in list(PAPER_CATEGORIES) + ['all']:
        draws = _draws(res, cat)
        if len(draws) < len(seeds):
            continue
        tolerant = [d.get('tolerant') if cat in LABEL_TOLERANT else None for d in draws]
        cells = [f"{d['mean']:.1f} / {d['median']:.1f}"
                 + (f" ({t['mean']:.1f} / {t['median']:.1f})" if t else '')
                 for d, t in zip(draws, tolerant)]
        mean, mean_either = _mean_over(draws, cat)
        over = f'{mean:.1f}' + (f' ({mean_either:.1f})' if mean_either is not None else '')
        paper = f'{PAPER_POSE[cat][0]} / {PAPER_POSE[cat][1]}' if cat in PAPER_POSE else ''
        lines.append(f"| {cat} | {' | '.join(cells)} | {over} | {paper} |")
    return lines + ['']


def pose_md(summary: dict, methods, paper: bool = True) -> list[str]:
    """
    Return a pose table: each method's rotation errors per category.

    Beside them, the errors up to the labels (metrics.label_tolerant_deg) for the categories whose
    labels lay the horizontal axes either way, and over all with those.
    """
    lines = ['| category | method | mean ° | median ° | < 5° | < 10° | < 30° | median ms | '
             'labels either way: mean ° / median ° / < 10° |',
             '|---|---|---|---|---|---|---|---|---|']
    for cat in list(PAPER_CATEGORIES) + ['all']:
        if cat not in summary:
            continue
        for m in methods:
            d = summary[cat].get(m)
            if not d:
                continue
            either = _either(d, cat)
            lines.append(
                f"| {cat} | {pose_table.METHODS[m]} | {d['mean']:.2f} | {d['median']:.2f} | "
                f"{_pct(d['under_5'])} | {_pct(d['under_10'])} | {_pct(d['under_30'])} | "
                f"{d['median_ms']:.0f} | {either} |"
            )
        if paper and cat in PAPER_POSE:
            lines.append(
                f'| {cat} | *paper: PCRP* | *{PAPER_POSE[cat][0]}* | *{PAPER_POSE[cat][1]}* | | | '
                '| | |'
            )
            lines.append(
                f'| {cat} | *paper: best learned (Chen et al.)* | *{CHEN_POSE[cat][0]}* | '
                f'*{CHEN_POSE[cat][1]}* | | | | | |'
            )
    return lines + ['', LABELS_NOTE, '']


def failure_bands(res: dict) -> list[str]:
    """
    Where this package's large pose errors lie.

    Near 90° they are the data's quarter turns, near 180° half turns of near-symmetric shapes.
    """
    uni = res.get('pose', {}).get('uniform')
    if not uni:
        return []
    lines = [
        "Errors over 30° of this package's defaults (uniform rotations), by where they lie:",
        '',
        '| category | queries | over 30° | 80–100° | 160–180° | elsewhere |',
        '|---|---|---|---|---|---|',
    ]
    for cat in PAPER_CATEGORIES:
        e = np.array([r['pcrp']['error'] for r in uni['rows'] if r['category'] == cat])
        if not len(e):
            continue
        big = e[e > 30]
        quarter, half = np.sum((big >= 80) & (big <= 100)), np.sum(big >= 160)
        lines.append(
            f'| {cat} | {len(e)} | {len(big)} | {quarter} | {half} | {len(big) - quarter - half} |'
        )
    return lines + ['']


VIEW_BAR = 0.70  # unseen instances seen one-sided: the share asked within 10°


def category_view_bar(res: dict) -> list[str]:
    """Return the category-level one-sided bar: within 10° on >= 70 %, labels either way."""
    got = []
    for name, section in (('the default gallery', res['pose']['view']),
                          (f'the gallery built with `--views {VIEWS}`',
                           res.get('partial_views', {}).get('view'))):
        t = (section or {}).get('summary', {}).get('all', {}).get('pcrp', {}).get('tolerant')
        if t:   # one decimal: 69.5 % must not read as a met 70 %
            met = 'met' if t['under_10'] >= VIEW_BAR else '**missed**'
            got.append(f"{100 * t['under_10']:.1f} % ({met}) with {name}")
    if not got:
        return []
    return [
        "The bar for unseen instances seen one-sided (PCRP's defaults, airplane and car up to "
        f'their labels): within 10° on at least {100 * VIEW_BAR:.0f} % of the queries; measured '
        f"{', '.join(got)}.",
        '',
    ]


def holdout_md(res: dict) -> list[str]:
    """
    Held-out train objects beside the test split's figures.

    Is the margin the defaults' or the test set's?
    """
    ho = res['holdout']
    test = res.get('pose', {}).get('uniform', {}).get('summary', {})
    lines = [
        '## Held-out check: objects no default was chosen on',
        '',
        "This package's defaults (candidate count, vote weights, refinement) were chosen while "
        "looking at the test split's queries under seeds 0-3, since the paper's protocol has no "
        'validation split. Here the queries are train objects kept out of the gallery and out of '
        'the Saab and codebook fits (a model built without them), under uniformly random '
        "rotations, each against the rest of its category's train split. Their frames are audited "
        'as above, against the train objects that stayed in. Mean / median rotation error in '
        'degrees:',
        '',
        '| category | held-out objects | nearest look-alike agrees | PCRP (defaults) | < 5° '
        '| PCRP told which way is up | PCRP as the paper describes it | Open3D RANSAC + ICP '
        '| PCRP on the test split (above) | PCRP, labels either way |',
        '|---|---|---|---|---|---|---|---|---|---|',
    ]
    for cat in PAPER_CATEGORIES:
        d, f = ho['summary'].get(cat), ho['frames'].get(cat)
        if not d or not f:
            continue
        mm = {m: f"{d[m]['mean']:.1f} / {d[m]['median']:.1f}" if m in d else ''
              for m in ('pcrp', 'pcrp_up', 'pcrp_paper', 'ransac_icp')}
        t = test.get(cat, {}).get('pcrp')
        on_test = f"{t['mean']:.1f} / {t['median']:.1f}" if t else ''
        either = ''
        if cat in LABEL_TOLERANT and 'tolerant' in d['pcrp']:
            h, o = d['pcrp']['tolerant'], (t or {}).get('tolerant')
            either = f"{h['mean']:.1f} / {h['median']:.1f}" + (
                f" (test split {o['mean']:.1f} / {o['median']:.1f})" if o else ''
            )
        lines.append(
            f"| {cat} | {f['objects']} | {_pct(f['nearest_agrees'])} | {mm['pcrp']} | "
            f"{_pct(d['pcrp']['under_5'])} "
            f"| {mm['pcrp_up']} | {mm['pcrp_paper']} | {mm['ransac_icp']} | {on_test} "
            f'| {either} |'
        )
    lines += [
        '',
        'Where the nearest look-alike agrees less often than among the test objects, more of the '
        'held-out objects cannot come back right whatever the method (see "What the data '
        'allows"); the paper-as-described and Open3D columns, run on the same queries, show how '
        "much of a difference is the objects' and how much the defaults'. \"Told which way is "
        "up\" passes each query the direction its gallery's up axis truly points "
        "(`estimate(up=...)`, the node's `up_vector`, with the default 60° tolerance): what a "
        'robot that knows gravity gets.',
        '',
    ]
    return lines


def frames_md(summary: dict) -> list[str]:
    lines = [
        '## What the data allows: how consistently each category is aligned',
        '',
        "A gallery-based method answers in its gallery's frame, so a test object whose own frame "
        "differs from its look-alikes' cannot come back right, however good the registration. For "
        'each test object, its nearest train object of the category by shape (symmetric chamfer '
        'on 128 points, under the best of the 24 rotations that map axes onto axes): does that '
        'best rotation agree with the labels (identity), or is it a quarter or half turn? Nothing '
        'of this package is used; it bounds what any method that retrieves the nearest look-alike '
        "and registers it perfectly could reach (the look-alike's error column: that method's "
        'mean / median). The last column needs no matching at all: among the objects at least '
        f'{frames.ELONGATED:g}× longer than wide, the share whose long side the labels lay along '
        'y (z is up).',
        '',
        '| category | test objects | nearest look-alike agrees | off by a quarter turn | off by a '
        'half turn | train objects agreeing with a test object (median) | perfect registration to '
        'the look-alike: mean / median | long side along y: train / test |',
        '|---|---|---|---|---|---|---|---|',
    ]
    for cat in PAPER_CATEGORIES:
        d = summary.get(cat)
        if d:
            ls = d.get('long_side')
            sides = (f"{_pct(ls['train']['along_y'])} of {ls['train']['elongated']} / "
                     f"{_pct(ls['test']['along_y'])} of {ls['test']['elongated']}") if ls else '–'
            lines.append(
                f"| {cat} | {d['objects']} | {_pct(d['nearest_agrees'])} | "
                f"{_pct(d['quarter_turns'])} | {_pct(d['half_turns'])} | "
                f"{_pct(d['share_agreeing_median'])} | {_f(d.get('look_alike_mean_deg'), 1)}° / "
                f"{_f(d.get('look_alike_median_deg'), 1)}° | {sides} |"
            )
    consistent = [
        c for c in PAPER_CATEGORIES if c in summary and summary[c]['nearest_agrees'] >= 0.9
    ]
    other = [c for c in PAPER_CATEGORIES if c in summary and c not in consistent]
    if consistent:
        lines += [
            '',
            f'{_names(consistent)} are consistently aligned: their bars are reachable, and met or '
            "missed on the method's merits.",
        ]
    if other:
        turned = ', '.join(f"{c} {_pct(1 - summary[c]['nearest_agrees'])}" for c in other)
        lines += [
            '',
            f'{_names(other)} are not (test objects turned against their nearest look-alike: '
            f'{turned}): a mean error of a few degrees would take guessing which way each test '
            'object was turned when it was labelled, which no shape cue measured here predicts; '
            'on this copy of the data their medians and shares under 5° are the comparable '
            'figures.',
        ]
    car = summary.get('car', {}).get('long_side')
    # the smaller share: off by a quarter turn whichever single way a method answers
    minority = min(car['test']['along_y'], 1 - car['test']['along_y']) if car else 0.0
    if minority > 0.1:
        lines += [
            '',
            "A car's long side is its length, however it was labelled: the labels lay it along y "
            f"for {_pct(car['train']['along_y'])} of the train cars and "
            f"{_pct(car['test']['along_y'])} of the test cars, along x for the rest. A randomly "
            'rotated query does not show which way its labeller laid it, so a method answering '
            f'every car one way is a quarter turn off on at least {_pct(minority)} of them; a '
            f"mean under the paper's {PAPER_POSE['car'][0]}° allows at most "
            f"{_pct(PAPER_POSE['car'][0] / 90)} of them a quarter turn off. (An airplane's long "
            'side is its span for some and its length for others, so the same count does not '
            'settle airplanes; the look-alike columns do.)',
        ]
    return lines + ['']


def _names(cats) -> str:
    cats = [c + 's' for c in cats]
    text = cats[0] if len(cats) == 1 else ', '.join(cats[:-1]) + ' and ' + cats[-1]
    return text[0].upper() + text[1:]


def bar(res: dict) -> list[str]:
    """Return the issue's bar, each line measured against this run."""
    out = []
    uni = res.get('pose', {}).get('uniform', {}).get('summary')
    frames_of = res.get('frames', {}).get('summary', {})
    if uni:
        for cat in PAPER_CATEGORIES:
            d = uni.get(cat, {})
            if 'pcrp' not in d:
                continue
            ours = d['pcrp']
            best = min((m for m in CLASSICAL if m in d), key=lambda m: d[m]['median'])
            beat_paper = ours['mean'] < PAPER_POSE[cat][0] and ours['median'] < PAPER_POSE[cat][1]
            beat_classic = ours['mean'] < d[best]['mean'] and ours['median'] < d[best]['median']
            f = frames_of.get(cat)
            # where the labels themselves disagree, say what a perfect registration to the
            # look-alike would score
            bound = (
                (
                    ' (labels: perfect registration to the nearest look-alike scores '
                    f"{f['look_alike_mean_deg']:.1f}° / {f['look_alike_median_deg']:.1f}°)"
                )
                if f and f['nearest_agrees'] < 0.9 and not beat_paper
                else ''
            )
            tie = (' (both medians at the quarter turn)' if not beat_classic and
                   max(abs(ours['median'] - 90), abs(d[best]['median'] - 90)) < 1.0 else '')
            t = ours.get('tolerant') if cat in LABEL_TOLERANT else None
            either = (f" (labels either way: {t['mean']:.1f}° / {t['median']:.1f}°)" if t else '')
            draws = _draws(res, cat)
            if len(draws) > 1:
                mean, mean_either = _mean_over(draws, cat)
                either += f'; mean over {len(draws)} draws of the rotations {mean:.1f}°'
                if mean_either is not None:
                    either += f' (labels either way {mean_either:.1f}°)'
            verdict = ''
            if t:   # the same verdicts, every method's errors taken up to the labels
                rivals = [d[m]['tolerant'] for m in CLASSICAL if 'tolerant' in d.get(m, {})]
                rival = min(rivals, key=lambda r: r['median'], default=None)
                paper_t = t['mean'] < PAPER_POSE[cat][0] and t['median'] < PAPER_POSE[cat][1]
                classic_t = rival is None or (t['mean'] < rival['mean']
                                              and t['median'] < rival['median'])
                verdict = (f"; labels either way: paper {'yes' if paper_t else '**no**'}, "
                           f"classical {'yes' if classic_t else '**no**'}")
            out.append(
                f"| pose, {cat}, uniform rotations | mean / median {ours['mean']:.1f}° / "
                f"{ours['median']:.1f}°{either} vs paper {PAPER_POSE[cat][0]}° / "
                f'{PAPER_POSE[cat][1]}° '
                f"and {pose_table.METHODS[best]} {d[best]['mean']:.1f}° / "
                f"{d[best]['median']:.1f}° | paper: {'yes' if beat_paper else '**no**'}{bound}; "
                f"classical: {'yes' if beat_classic else '**no**'}{tie}{verdict} |"
            )
    ret = res.get('retrieval')
    if ret:
        for setting in ('aligned', 'arbitrary'):
            d = ret[setting]
            for key, name in (('p10_strict', 'strict'), ('p10_corsair', 'CORSAIR')):
                ratio = d['pcrp_vlad'][key] / max(d['fpfh_vlad'][key], 1e-9)
                out.append(
                    f"| retrieval, {setting}, P@10 {name} | PCRP {_pct(d['pcrp_vlad'][key])} vs "
                    f"FPFH + VLAD {_pct(d['fpfh_vlad'][key])}: {ratio:.2f}× (needed {RATIO:.2f}×) "
                    f"| {'yes' if ratio >= RATIO else '**no**'} |"
                )
            lower = d['pcrp_vlad']['top1_chamfer'] < d['fpfh_vlad']['top1_chamfer']
            out.append(
                f'| retrieval, {setting}, top-1 chamfer | PCRP '
                f"{d['pcrp_vlad']['top1_chamfer']:.3f} vs FPFH + VLAD "
                f"{d['fpfh_vlad']['top1_chamfer']:.3f} | {'yes' if lower else '**no**'} |"
            )
    if not out:
        return []
    return ['| bar | measured | met |', '|---|---|---|'] + out + ['']


def confidence_md(conf: dict, out: Path) -> list[str]:
    """
    Return the confidence section.

    The issue's targets per kind of cloud, a reliability table, plots.
    """
    from tools.paper_eval import confidence_table as ct
    sm, thr = conf['summary'], conf['threshold']
    L = [
        '## Confidence: when to act on an answer',
        '',
        "Each answer's confidence is the probability, learnt when the model was built on its own "
        'train objects (each queried as it is, with itself left out of the gallery, and with its '
        'whole category left out, and random solids of no category beside them; '
        '`pcrp_core/category/calibration.py`), that the answer is right: '
        f'the right category and a rotation within {pcrp_right_deg():.0f}° of the labels, or of '
        'laying the gallery object it answered with on the cloud (where the objects of a category '
        "disagree about which way is front, as this copy's airplanes and cars do, the answered "
        'object at the answered pose is what a user acts on). Queries: test objects '
        "of the gallery's four categories and of twelve it does not hold "
        f"({', '.join(ct.OUTSIDE)}; no choice was made on them), uniformly rotated, whole and "
        'one-sided; the four-category gallery. Right answers are accepted when their confidence '
        f'reaches the default `min_confidence` {thr}; an object from outside the gallery should '
        'be rejected.',
        '',
        "| clouds | right answers (of the gallery's categories) | right answers accepted (target "
        '≥ 95 %) | outside objects rejected (target ≥ 80 %) | ROC AUC right vs outside (target ≥ '
        "0.95) | wrong answers of the gallery's categories rejected | calibration error (ECE) |",
        '|---|---|---|---|---|---|---|',
    ]
    either = conf.get('summary_tolerant', {})
    clouds = (('whole', 'whole'), ('view', 'one-sided'), ('all', 'both'))
    kinds = [(sm, k, label) for k, label in clouds]
    kinds += [(either, k, f'{label}, labels either way') for k, label in clouds[:2]]
    for summary, kind, label in kinds:
        d = summary.get(kind)
        if not d:
            continue
        met = lambda key: ('' if d.get(key) is None or d[key] != d[key]  # noqa: E731
                           else (' (met)' if d[key] >= ct.TARGETS[key] else ' (**missed**)'))
        L.append(
            f"| {label} | {d['n_right']} of {d['n_inside']} | "
            f"{_pct(d['right_accepted'])}{met('right_accepted')} "
            f"| {_pct(d['outside_rejected'])} of {d['n_outside']}{met('outside_rejected')} "
            f"| {d.get('auc', float('nan')):.3f}{met('auc')} | {_pct(d['wrong_inside_rejected'])} "
            f"| {d['ece']:.3f} |"
        )
    if either:
        L += [
            '',
            'Labels either way: airplane and car answers judged up to a quarter or half turn of '
            'their labels about the up axis, as in the pose tables. For these two categories that '
            'is what the confidence was learnt to mean (an answer laying the object it answered '
            'with on the cloud is right), so those rows are the ones it is calibrated for; judged '
            'by their own labels, an airplane or car turned as its look-alikes are counts wrong '
            'however well it fits.',
        ]
    rel = sm.get('all', {}).get('reliability', [])
    rel_either = either.get('all', {}).get('reliability', [])
    if len(rel_either) != len(rel):  # results written before the column existed
        rel_either = [(c, float('nan'), n) for c, _, n in rel]
    L += [
        '',
        'Reliability over all these answers (a confidence that means what it says lies on the '
        'diagonal):',
        '',
        '| mean confidence in bin | share right | share right, labels either way | answers |',
        '|---|---|---|---|',
        *[f'| {c:.2f} | {r:.2f} | {e:.2f} | {n} |'
          for (c, r, n), (_, e, _) in zip(rel, rel_either)],
        '',
    ]
    if ct.plot(sm, out / 'confidence.png', either):
        L += ['![Reliability diagram and ROC curves](confidence.png)', '']
    return L


def pcrp_right_deg() -> float:
    from pcrp_core.category.evidence import RIGHT_DEG
    return RIGHT_DEG


def cdf_plot(res: dict, path: Path) -> bool:
    uni = res.get('pose', {}).get('uniform')
    if not uni:
        return False
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    rows = uni['rows']
    fig, axes = plt.subplots(1, 4, figsize=(16, 3.6), sharey=True)
    for ax, cat in zip(axes, PAPER_CATEGORIES):
        sel = [r for r in rows if r['category'] == cat]
        for m in pose_table.METHODS:
            if sel and m in sel[0]:
                e = np.sort([r[m]['error'] for r in sel])
                ax.step(e, np.arange(1, len(e) + 1) / len(e), where='post', label=m)
        ax.set_xscale('log')
        ax.set_xlim(0.3, 180)
        ax.set_title(cat)
        ax.set_xlabel('rotation error (°)')
        ax.grid(alpha=0.3)
    axes[0].set_ylabel('share of queries')
    axes[-1].legend(fontsize=8, loc='lower right')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return True


def examples_plot(res: dict, s, path: Path) -> bool:
    """
    One query per category (uniform rotation, default method).

    With the retrieved object moved onto it by the estimated pose.
    """
    from tools.paper_eval.models import category_model
    from tools.paper_eval.protocol import queries
    model_path = res.get('model4', {}).get('path')
    if not model_path or 'pose' not in res:
        return False
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    fig = plt.figure(figsize=(16, 4.2))
    for k, cat in enumerate(PAPER_CATEGORIES):
        q = queries(s.data, [cat], 'pose-uniform', s.seed, 1)[0]
        r = category_model(model_path, cat).estimate(q.points)
        g = category_model(model_path, cat).gallery_cloud(r.gallery_id).astype(np.float64)
        aligned = g @ r.rotation.T * r.scale + r.translation
        ax = fig.add_subplot(1, 4, k + 1, projection='3d')
        ax.scatter(*q.points.T, s=1, c='tab:blue', label='query')
        ax.scatter(*aligned.T, s=1, c='tab:orange', label=f'{r.gallery_id}, aligned')
        err = geodesic_deg(r.rotation, q.R)
        ax.set_title(f'{q.name}: error {err:.1f}°, score {r.score:.2f}', fontsize=9)
        ax.set_axis_off()
        ax.legend(fontsize=7, loc='upper left')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return True


def write_report(s, res: dict) -> Path:
    out = Path(s.out)
    per = res['per_category'] or 'all'
    sec = res['seconds']
    flags = (
        ''
        if res['per_category'] is None or res['quick']
        else f" --per-category {res['per_category']}"
    ) + (' --quick' if res['quick'] else '')
    minutes = sec.get('total', 0) / 60
    lines = [
        "# Evaluation on ModelNet40: the paper's experiments, the baselines beside them",
        '',
        'Regenerate with `python -m tools paper-eval --data ../shared/data/modelnet40 --out '
        f"docs/results --seed {res['seed']}{flags}`. Run {res['date']} on "
        f"{res['machine']['cores']} cores ({res['machine']['cpu']}), "
        f"{minutes:.0f} minute{'' if round(minutes) == 1 else 's'} in "
        f"all{' (with models built by an earlier run)' if None in sec.values() else ''}. Test "
        f'objects per category: {per}; every random rotation, translation, point order, cut and '
        f"viewpoint comes from seed {res['seed']} (run with `--seed N` to draw others).",
        '',
        'Data: `../shared/data/modelnet40`, 1024 points per object where the paper had 2048. '
        f"Gallery: the train split of airplane, chair, sofa and car ({res['model4']['objects']} "
        "objects), built with the package's defaults (`pcrp build`, seed 0); queries: their test "
        'split. Rotation error: the geodesic angle between estimated and true rotation. Times are '
        'per query, one core each (queries run in parallel, one per core).',
        '',
    ]
    if res.get('carried'):
        lines += ['Not rerun here, carried over from an earlier run of the same seed (`--keep`): '
                  + '; '.join(f'{k} (run {d})' for k, d in res['carried'].items()) + '.', '']
    b = bar(res)
    if b:
        lines += ['## The bar', '', *b]
    if 'frames' in res:
        lines += frames_md(res['frames']['summary'])
    if 'pose' in res and 'uniform' in res['pose']:
        lines += [
            "## Pose estimation (the paper's Table 3)",
            '',
            'Each test object under a uniformly random rotation and a translation in [-0.5, '
            '0.5]³, its points shuffled; gallery: the train split of its category. The classical '
            'pipelines register to the object PCRP retrieved (its FPFH computed beforehand, '
            'untimed), so only the registration differs.',
            '',
            *pose_md(res['pose']['uniform']['summary'], pose_table.METHODS),
        ]
        if cdf_plot(res, out / 'pose_cdf.png'):
            lines += ['![Rotation error CDF per category and method](pose_cdf.png)', '']
        if examples_plot(res, s, out / 'pose_examples.png'):
            lines += [
                'Queries (blue) with the retrieved gallery object moved onto them by the '
                'estimated pose (orange):',
                '',
                '![Examples](pose_examples.png)',
                '',
            ]
    if 'seeds' in res and 'pose' in res and 'uniform' in res['pose']:
        lines += seeds_md(res)
    if 'pose' in res and 'euler45' in res['pose']:
        lines += ['### The narrower protocol: each Euler angle in [0°, 45°]', '',
                  *pose_md(res['pose']['euler45']['summary'], pose_table.METHODS, paper=False)]
    if 'holdout' in res:
        lines += holdout_md(res)
    if 'pose' in res and 'view' in res['pose']:
        lines += [
            '## Partial views: what a depth camera sees',
            '',
            'Each query cut to the points a sensor 3 radii away in a random direction sees, with '
            f"range noise of {VIEW_NOISE} radii along each ray; the sensor's position is given to "
            'PCRP (as the node does for clouds in the camera frame). Gallery: the train split of '
            "the query's category.",
            '',
            *pose_md(res['pose']['view']['summary'], pose_table.VIEW_METHODS, paper=False),
        ]
        if 'partial_views' in res:
            lines += [
                f'The same queries against the same gallery built with `--views {VIEWS}` '
                f'(descriptors of {VIEWS} one-sided views of each object stored beside its own, '
                'as the README recommends for depth cameras):',
                '',
                *pose_md(
                    res['partial_views']['view']['summary'],
                    pose_table.ROBOT_VIEW_METHODS,
                    paper=False,
                ),
            ]
        lines += category_view_bar(res)
    if 'instances' in res:
        ins = res['instances']
        lines += [
            "## Known objects: the robot's case",
            '',
            "The gallery holds the very objects the robot meets: the four categories' "
            f"{ins['objects']} test objects, built into a model with the defaults and `--views "
            f'{VIEWS}`. Each is queried under a uniformly random rotation, whole with Gaussian '
            f'noise of {INSTANCE_NOISE} radii on every point, and one-sided as a depth camera 3 '
            'radii away in a random direction sees it. Right object: the gallery object retrieved '
            "is the query's own. The Open3D pipelines register to the object PCRP retrieved.",
            '',
        ]
        for name, title in (('whole', 'Whole objects, noisy'), ('view', 'One-sided views')):
            if name in ins:
                acc = ', '.join(
                    f"{c} {_pct(ins[name]['summary'][c]['object_accuracy'])}"
                    for c in list(PAPER_CATEGORIES) + ['all']
                    if c in ins[name]['summary']
                )
                rows = ins[name]['rows']
                rej = np.array([r['rejected'] for r in rows])
                right = np.array(
                    [
                        r['retrieved'] == r['name'] and r['pcrp']['error'] < pose_table.RIGHT_DEG
                        for r in rows
                    ]
                )
                lines += [
                    f'**{title}** (right object: {acc}). At the default `min_confidence` the '
                    f'model rejects {_pct(rej.mean())} of these clouds: '
                    f'{_pct((rej & right).mean())} of all were right, '
                    f'{_pct((rej & ~right).mean())} wrong; {_pct((~rej & ~right).mean())} are '
                    'wrong but accepted.',
                    '',
                    *pose_md(ins[name]['summary'], pose_table.ROBOT_VIEW_METHODS, paper=False),
                ]
    if 'registration' in res:
        lines += [
            "## Registration (the paper's Table 1)",
            '',
            'Each test object registered to a copy of itself under a random rotation (each Euler '
            'angle uniform in [0°, 45°]) and translation (uniform in [-0.5, 0.5] per axis), '
            'points shuffled. Errors are over the three x-y-z Euler angles (degrees) and the '
            'three translation components. The partial copy keeps one side of a random plane, the '
            'whole object is the target.',
            '',
            *registration_md(res['registration']),
        ]
    if 'retrieval' in res:
        lines += [
            "## Retrieval (the paper's Table 2)",
            '',
            'Each query searches the train split of its category. Ground truth: that gallery '
            'ranked by the chamfer distance to the unrotated query, where chamfer(A, B) = mean '
            'over A of the distance to the nearest point of B, plus the same from B to A '
            "(unit-sphere radii, on 512 of each object's points). P@10 strict: the share of the "
            "method's top 10 among the 10 nearest by chamfer; CORSAIR's: the share among the "
            'nearest 10 % of the gallery. Top-1 chamfer: from the query to the first object '
            'retrieved. Arbitrary: uniformly random rotation and translation.',
            '',
            *retrieval_md(res['retrieval']),
        ]
    if 'large' in res:
        lg = res['large']
        lines += [
            '## A larger gallery: all 40 categories',
            '',
            f"Gallery: the train split of all 40 categories ({lg['objects']} objects); queries: "
            'the four '
            "categories' test objects under uniform rotations, searched over the whole gallery.",
            '',
            '| category | category right | mean ° | median ° | < 10° | rejected | median ms | '
            'labels either way: mean ° / median ° / < 10° |',
            '|---|---|---|---|---|---|---|---|',
        ]
        for cat in list(PAPER_CATEGORIES) + ['all']:
            d = lg['summary'].get(cat)
            if d and 'pcrp' in d:
                p = d['pcrp']
                either = _either(p, cat)
                lines.append(
                    f"| {cat} | {_pct(d['category_accuracy'])} | {p['mean']:.2f} | "
                    f"{p['median']:.2f} | "
                    f"{_pct(p['under_10'])} | {_pct(d['rejected'])} | {p['median_ms']:.0f} | "
                    f'{either} |'
                )
        lines += ['', LABELS_NOTE, '']
    if 'rejection' in res:
        lines += rejection_md(res['rejection'])
    if 'confidence' in res:
        lines += confidence_md(res['confidence'], out)
    lines += ['## Reading these figures', '', *failure_bands(res), NOTES, '']
    lines += [
        '## Run time',
        '',
        '| part | minutes |',
        '|---|---|',
        *[
            f"| {k} | {'cached from an earlier run' if v is None else f'{v / 60:.1f}'} |"
            for k, v in sec.items()
        ],
        '',
    ]
    path = out / 'RESULTS.md'
    path.write_text('\n'.join(lines))
    return path
