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

"""BENCHMARKS.md's plot: how the cost grows with the gallery and the cloud, with fitted slopes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

GROWTH_PLOT = 'bench_growth.png'


def slope(xs, ys) -> float:
    """Log-log slope of ys against xs: 0 flat, 1 linear."""
    return float(np.polyfit(np.log(xs), np.log(ys), 1)[0])


def growth_series(res: dict) -> tuple[list, list]:
    """
    Return the (label, sizes, median ms) series against the gallery's size and the cloud's.

    From a bench run's results: the camera views' growth part and the ModelNet40 scale part, each
    where the run has it.
    """
    by_gallery, by_points = [], []
    g = (res.get('views') or {}).get('growth')
    if g:
        n = [r['objects'] for r in g['gallery']]
        answer = [r['match']['median_ms'] for r in g['gallery']]
        shortlist = [r['shortlist']['median_ms'] for r in g['gallery']]
        by_gallery += [('YCB view, whole answer (one thread)', n, answer),
                       ('YCB view, shortlist (one thread)', n, shortlist)]
        points = [r['points'] for r in g['points']]
        by_points.append(('YCB view, whole answer (one thread)', points,
                          [r['estimate']['median_ms'] for r in g['points']]))
    scale = res.get('scale') or []
    if len(scale) > 1:
        n = [r['objects'] for r in scale]
        by_gallery += [('ModelNet40 retrieval, features + search', n,
                        [r['retrieve']['median_ms'] for r in scale]),
                       ('ModelNet40 search alone', n, [r['search']['median_ms'] for r in scale])]
    return by_gallery, by_points


def growth_plot(res: dict, path: Path) -> bool:
    """Draw the growth series on log-log axes, each labelled with its fitted slope."""
    by_gallery, by_points = growth_series(res)
    if not by_gallery:
        return False
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    panels = ((axes[0], by_gallery, 'objects in the gallery'),
              (axes[1], by_points, 'points in the cloud'))
    for ax, series, xlabel in panels:
        for label, xs, ys in series:
            ax.plot(xs, ys, 'o-', label=f'{label}: slope {slope(xs, ys):.2f}')
        ax.axhline(10.0, color='grey', lw=0.8, ls=':')
        ax.set_xscale('log')
        ax.set_yscale('log')
        ax.set_xlabel(xlabel)
        ax.set_ylabel('median ms')
        ax.grid(alpha=0.3, which='both')
        ax.legend(fontsize=8)
    axes[0].set_title('against the gallery (dotted: 10 ms)')
    axes[1].set_title('against the cloud')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return True
