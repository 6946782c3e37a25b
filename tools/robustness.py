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
`python -m tools robustness`: regenerate docs/results/ROBUSTNESS.md.

What the node did with every bad input, broken model file and damaged bag we could think of, and
the soak figures.

Every row comes from running the real thing (the node over DDS, the node and CLI as
processes, the bag commands on real bag files), through the same catalogues the tests use.
"""
from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path
import platform
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

REPORT = 'ROBUSTNESS.md'


# -- bags with surprises --------------------------------------------------------------------------
def mixed_bag(path: Path) -> dict:
    """
    Write a bag as a user may hand it over.

    Clouds on the expected topic and on another one, a cloud without a z field, and a topic of
    another type.

    Returns what was written.
    """
    from pcrp_core.sources import load_source
    from pcrp_ros.bags import BagWriter, cloud_msg, header, T

    objs = load_source('procedural:5', split='train')[:3]
    with BagWriter(path) as bag:
        for k, o in enumerate(objs):
            ts = (k + 1) * 10**9
            bag.write(
                'segmented_object', cloud_msg(o.points + [0, 0, 3], header(k + 1, 0, 'cam')), ts
            )
            bag.write(
                'other/points', cloud_msg(o.points + [0, 0, 3], header(k + 1, 1, 'cam')), ts + 1
            )
            bag.write('chatter', T['std_msgs/msg/String'](data='hello'), ts + 2)
        no_z = cloud_msg(objs[0].points, header(9, 0, 'cam'))
        no_z.fields = no_z.fields[:2]
        bag.write('segmented_object', no_z, 9 * 10**9)
    return {'segmented_object': 4, 'other/points': 3, 'chatter': 1 * len(objs)}


def truncated_bag(path: Path, storage: str = 'mcap', keep: float = 0.6) -> int:
    """
    Write a bag of 6 clouds and cut its file to `keep` of its bytes.

    As a recorder killed mid-write leaves it. Returns the number of clouds written.
    """
    from pcrp_ros.bag_commands import make_bag

    n = make_bag(path, 'procedural:5', count=6, rate=10, seed=1, storage=storage)
    f = next(path.glob('*.mcap' if storage == 'mcap' else '*.db3'))
    raw = f.read_bytes()
    f.write_bytes(raw[: int(len(raw) * keep)])
    return n


def _pcrp(*args) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, '-m', 'pcrp_ros.cli', *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
    )


def run_bag_faults(work: Path) -> list[dict]:
    """`pcrp process` and `pcrp replay` on damaged and surprising bags, as a user runs them."""
    rows = []
    trunc, trunc_sql = work / 'truncated_mcap', work / 'truncated_sqlite'
    sent = truncated_bag(trunc)
    truncated_bag(trunc_sql, 'sqlite3')
    mixed = work / 'mixed'
    mixed_bag(mixed)
    for name, bag, args, what in (
        ('truncated_mcap', trunc, [], f'MCAP recording cut at 60 % ({sent} clouds written)'),
        ('truncated_sqlite', trunc_sql, [], f'SQLite bag cut at 60 % ({sent} clouds written)'),
        ('mixed_all', mixed, [], 'clouds on two topics, one without z, plus a String topic'),
        (
            'mixed_one_topic',
            mixed,
            ['--topics', 'segmented_object'],
            'the same, asking for one topic',
        ),
        ('absent_topic', mixed, ['--topics', 'no/such/topic'], 'asking for a topic the bag lacks'),
    ):
        out_bag = work / f'{name}_out'
        shutil.rmtree(out_bag, ignore_errors=True)
        proc = _pcrp('process', bag, '--out', out_bag, *args)
        answered, refused = _tally(proc.stdout)
        rep = _pcrp('replay', bag, '--rate-factor', '50', *args)
        rows.append(
            {
                'name': name,
                'what': what,
                'process_exit': proc.returncode,
                'process_said': _said(proc.stderr),
                'answered': answered,
                'refused': refused,
                'replay_exit': rep.returncode,
                'replay_said': _said(rep.stderr),
                'replay_published': _published(rep.stdout),
            }
        )
    return rows


def _tally(stdout: str) -> tuple[int, int]:
    """(answered, refused) from process's summary line 'clouds N, answered A, rejected R'."""
    for line in stdout.splitlines():
        if line.startswith('clouds '):
            parts = dict(p.strip().split(' ', 1) for p in line.split(','))
            return int(parts['answered']), int(parts['rejected'])
    return 0, 0


def _said(stderr: str) -> str:
    lines = [line.split(': ', 2)[-1] for line in stderr.splitlines() if line.startswith('pcrp')]
    return '; '.join(lines)


def _published(stdout: str) -> int:
    for line in stdout.splitlines():
        if line.startswith('published '):
            return int(line.split()[1])
    return -1


# -- running the catalogues -----------------------------------------------------------------------
def run_cases(model) -> list[tuple]:
    from tools.bad_clouds import accepted, CaseRunner, CASES, judged_good_cloud

    def line(case, out):
        return f'  {case.name:18s} {out.outcome:28s} next good cloud: {out.next_good}'

    return _battery(model, None, 'pcrp_robustness',
                    lambda node, client: CaseRunner(node, client, judged_good_cloud(model)),
                    'the node did not answer a good cloud within a minute', CASES, accepted, line)


def run_scene_cases(model) -> list[tuple]:
    from tools.bad_scenes import accepted, camera_frame, CASES, node_parameters, SceneCaseRunner

    def line(case, out):
        return (f'  {case.name:18s} {out.counted:32s} cloud {out.cloud}, '
                f'next good frame: {out.next_good}')

    # CASES in order: the first needs a node that has had no CameraInfo
    return _battery(model, node_parameters(), 'pcrp_scene_robustness',
                    lambda node, client: SceneCaseRunner(node, client, camera_frame(model)),
                    'the node did not subscribe its scene topics within 30 s', CASES, accepted,
                    line)


def _battery(model, overrides, client_name: str, make_runner, not_ready: str, cases,
             accepted, line) -> list[tuple]:
    """
    Return (case, outcome, accepted) of each case run, in order, on one node.

    The node runs with overrides (its parameter_overrides, or None) beside a client node;
    make_runner(node, client) gives the battery's runner; not_ready is the error when the node
    never gets ready; line(case, outcome) is what is printed of each.
    """
    from pcrp_ros.node import PcrpNode
    from pcrp_ros.spinning import ros_context, spinning
    import rclpy

    rows = []
    with ros_context() as ctx:
        node = PcrpNode(model=model, context=ctx, parameter_overrides=overrides)
        client = rclpy.create_node(client_name, context=ctx)
        runner = make_runner(node, client)
        with spinning(ctx, node, client):
            if not runner.ready():
                raise RuntimeError(not_ready)
            for case in cases:
                out = runner.run(case)
                rows.append((case, out, accepted(case, out)))
                print(line(case, out), flush=True)
    return rows


def run_faults(model_dir: Path, work: Path) -> list[tuple]:
    from tools.faults import FAULTS, handled, try_fault

    cloud = work / 'cloud.npy'
    np.save(cloud, np.random.default_rng(0).normal(size=(500, 3)))
    rows = []
    for fault in FAULTS:
        results = try_fault(fault, model_dir, work, cloud)
        ok = [handled(fault, r, str(work / fault.name)) for r in results]
        rows.append((fault, results, ok))
        print(
            f'  {fault.name:20s} node exit {results[0].returncode}, '
            f'cli exit {results[1].returncode}',
            flush=True,
        )
    return rows


# -- the report -----------------------------------------------------------------------------------
def _allowed(case) -> str:
    from tools.bad_clouds import ANSWERED, ANY_ANSWER
    names = {ANSWERED: 'answered right', ANY_ANSWER: 'answered'}
    return ' or '.join(
        names.get(a, a.replace('rejected:', 'refused: ')) for a in sorted(case.allowed)
    )


def _outcome(out) -> str:
    from tools.bad_clouds import ANSWERED, ANY_ANSWER
    if out.outcome == ANSWERED:
        return f'answered right ({out.gallery_id}, {out.rotation_error:.1f}°)'
    if out.outcome == ANY_ANSWER:
        return (
            f"answered ({out.gallery_id}, {out.rotation_error:.0f}° off the source object's pose)"
        )
    return out.outcome.replace('rejected:', 'refused: ')


def _short(path_text: str, work: Path) -> str:
    return path_text.replace(str(work) + '/', '…/').replace('|', '\\|')


def _stale_share(soak: dict) -> float:
    topics = soak['per_topic'].values()
    good = sum(d['sent_good'] for d in topics)
    return sum(d['dropped_stale'] for d in topics) / good if good else 0.0


def _scene_section(scene_cases) -> list[str]:
    from tools.bad_scenes import IMAGE_TOPIC, VIEW_OBJECT
    lines = [
        '## Bad depth images, sent as the scene of a good cloud',
        '',
        f'The node with `scene_topics: [{IMAGE_TOPIC}]` and `scene_type: depth_image` (the '
        "camera's depth images as scenes, docs/node.md). Each depth image below is built from one "
        f"640 x 480 frame of the shipped gallery's {VIEW_OBJECT} in front of a wall and "
        'published, with the CameraInfo shown (else the last one stands), before the segmented '
        'cloud of the same stamp. The cloud must be answered, with the frame or without it, and '
        'the frame counted once under the count shown (`scene_*` in `/diagnostics`, logged once '
        'per reason per `log_throttle_sec`). After each, the good frame and its CameraInfo are '
        'sent again with their cloud: the frame must be used and the cloud answered. In this '
        'order: the first case needs a node that has had no CameraInfo.',
        '',
        '| case | what was sent | counted | what the node did | cloud | decided after '
        '| next good frame | verdict |',
        '|---|---|---|---|---|---|---|---|',
    ]
    for case, out, ok in scene_cases:
        lines.append(
            f'| `{case.name}` | {case.what} | {case.counted} | {out.counted} | {out.cloud} '
            f"| {out.seconds:.2f} s | {out.next_good} | {'pass' if ok else 'FAIL'} |"
        )
    return lines + [
        '',
        'An image with nothing measured in it (0, NaN or negative depths) is a usable frame '
        'that hides nothing; one whose CameraInfo does not fit it (another size, no focal '
        "lengths, another camera's frame) is refused rather than read with the wrong camera.",
        '',
    ]


def write_report(out_dir: Path, cases, scene_cases, faults, bags, soak, work: Path,
                 command: str) -> Path:
    from tools import soak as soak_mod
    out_dir.mkdir(parents=True, exist_ok=True)
    lines = [
        '# Robustness: what the node does with bad input, broken files and load',
        '',
        f'Regenerate with `{command}` '
        f"(about {'15' if soak and soak['duration_s'] >= 600 else 'a few'} minutes). "
        f"Made {time.strftime('%Y-%m-%d')} on {platform.machine()}, "
        f'Python {platform.python_version()}. '
        'Every row below was produced by running the real thing, and the same catalogues '
        '(`tools/bad_clouds.py`, `tools/bad_scenes.py`, `tools/faults.py`, '
        '`tools/robustness.py`) are run by the test suite (`test/ros/test_node_robustness.py`, '
        '`test/ros/test_scene_robustness.py`, `test/integration/test_bags.py`), so each row is '
        'also a passing test.',
        '',
        '## Bad clouds, sent to the running node over DDS',
        '',
        'Each cloud below is built from one good cloud (one side of a gallery object, as a depth '
        'camera sees it) and published to the node with its default parameters. After each, the '
        'good cloud is sent again: it must be answered with the right gallery ID and under 10° of '
        'rotation error. Refusals are counted in `/diagnostics` under the reason shown and logged '
        'once per reason per `log_throttle_sec`.',
        '',
        '| case | what was sent | allowed | what the node did | decided after | next good cloud '
        '| verdict |',
        '|---|---|---|---|---|---|---|',
    ]
    for case, out, ok in cases:
        lines.append(
            f'| `{case.name}` | {case.what} | {_allowed(case)} | {_outcome(out)} '
            f'| {out.seconds:.2f} s '
            f"| {out.next_good.replace('answered', 'answered right')} "
            f"| {'pass' if ok else 'FAIL'} |"
        )
    lines += [
        '',
        "Units: the node takes clouds to be in the gallery's units (`scale_mode: metric`). "
        'Millimetre clouds are refused for their fit, not misread; with `scale_mode: normalize` '
        'they are answered with their scale '
        '(`test_a_cloud_in_millimetres_is_answered_or_rejected_not_crashed`). A sphere, a cube '
        'or a plane has no orientation to find; the node may answer or refuse them, never crash.',
        '',
    ]
    lines += _scene_section(scene_cases)
    lines += [
        '## Broken model files, at start-up',
        '',
        'A damaged copy of the shipped model is handed to the node '
        '(`python -m pcrp_ros.node --ros-args -p model_path:=…`) and to the CLI '
        '(`pcrp query MODEL CLOUD`). Both must stop with one error line naming the file and the '
        'problem, a non-zero exit and no traceback. Nothing is unpickled: `arrays.npz` is read '
        'with `allow_pickle=False`, so the pickled object below is refused even with a valid '
        'checksum.',
        '',
        '| fault | node exit | CLI exit | the one line the node printed | verdict |',
        '|---|---|---|---|---|',
    ]
    for fault, results, ok in faults:
        node, cli = results
        line = node.error_lines()[0] if node.error_lines() else ''
        lines.append(
            f'| `{fault.name}`: {fault.what} | {node.returncode} | {cli.returncode} '
            f'| {_short(line, work)} '
            f"| {'pass' if all(ok) else 'FAIL'} |"
        )
    lines += [
        '',
        '## Damaged and surprising bags',
        '',
        '`pcrp process BAG --out OUT` and `pcrp replay BAG` (no node listening) on bags made for '
        'the purpose. Both say on stderr what they could not use and carry on with what they '
        'could read; they exit 1 only when nothing at all could be read.',
        '',
        '| bag | process: exit, clouds answered / refused | what process said '
        '| replay: exit, clouds published | what replay said |',
        '|---|---|---|---|---|',
    ]
    for b in bags:
        lines.append(
            f"| {b['what']} | {b['process_exit']}, {b['answered']} / {b['refused']} "
            f"| {_short(b['process_said'], work) or '-'} "
            f"| {b['replay_exit']}, {b['replay_published']} "
            f"| {_short(b['replay_said'], work) or '-'} |"
        )
    lines += [
        '',
        '## While running: publishers, QoS, other instances',
        '',
        '| situation | what happens | checked by |',
        '|---|---|---|',
        '| a publisher leaves and another starts on the same topic '
        "| the new one's clouds are answered "
        '| `test_publishers_that_come_and_go_and_reliable_ones_are_all_answered` |',
        "| a publisher with reliable QoS (the node's input is best effort) | matched and answered "
        '| same test |',
        '| a second node instance on the same topics (named apart: `-r __node:=pcrp_node_2`) '
        '| each answers each cloud once with the same pose; `/diagnostics` keeps them apart '
        'by node name | `test_a_second_instance_answers_alongside_with_its_own_diagnostics` |',
        '| clouds faster than the node can answer '
        '| newest kept per topic, the rest counted as `dropped_stale`; nothing queues '
        '| the soak below |',
        '| Ctrl-C | clean exit, code 0 | the soak below |',
        '',
    ]
    if soak:
        published_with = (f"config/{soak['driver_profile']}" if soak.get('driver_profile')
                          else 'Fast DDS defaults')
        lines += [
            f"## Soak: {soak['topics']} topics at {soak['rate_hz']:g} Hz "
            f"for {soak['duration_s'] / 60:g} minutes",
            '',
            'The node as its own process (`python -m tools soak`), '
            f"{soak['bad_share']:.0%} of the clouds bad (the refusals of the first table that are "
            'decided on arrival, in turn), the rest good one-sided views of 16 gallery '
            f"objects (the demo bag's camera views), published with {published_with} as "
            'docs/node.md advises a segmenter. Latency is from arrival to publication; age from '
            f"the cloud's stamp to publication. {_stale_share(soak):.0%} of the good clouds were "
            'dropped as stale: by design, a node that falls behind answers the newest clouds of '
            'each topic and never builds a backlog.',
            '',
            soak_mod.table(soak),
            '',
        ]
    path = out_dir / REPORT
    path.write_text('\n'.join(lines))
    data = {
        'cases': [
            {
                'case': c.name,
                'outcome': o.outcome,
                'seconds': o.seconds,
                'gallery_id': o.gallery_id,
                'rotation_error': None if np.isnan(o.rotation_error) else o.rotation_error,
                'next_good': o.next_good,
                'pass': ok,
            }
            for c, o, ok in cases
        ],
        'faults': [
            {
                'fault': f.name,
                'node_exit': r[0].returncode,
                'cli_exit': r[1].returncode,
                'node_line': _short(r[0].error_lines()[0] if r[0].error_lines() else '', work),
                'pass': all(ok),
            }
            for f, r, ok in faults
        ],
        'bags': [
            {k: (_short(v, work) if isinstance(v, str) else v) for k, v in b.items()} for b in bags
        ],
        'soak': soak,
    }
    (out_dir / 'robustness.json').write_text(json.dumps(data, indent=1, default=str))
    return path


def register(sub) -> None:
    p = sub.add_parser(
        'robustness',
        help='try every bad input, broken model and damaged bag; soak; write ROBUSTNESS.md',
    )
    p.add_argument('--out', default='docs/results')
    p.add_argument(
        '--soak-duration', type=float, default=600.0, help='seconds; 0 to skip the soak'
    )
    p.add_argument('--quick', action='store_true', help='a 20 s soak on 2 topics instead')
    p.set_defaults(func=_run)


def _run(args) -> int:
    from pcrp_core import default_model_path, PCRP
    from tools import soak as soak_mod

    command = (
        'python -m tools robustness'
        + (' --quick' if args.quick else '')
        + (
            f' --soak-duration {args.soak_duration:g}'
            if args.soak_duration != 600 and not args.quick
            else ''
        )
    )
    # before this process's first DDS participant, which the bad-cloud cases create
    soak_mod.use_driver_profile(soak_mod.LARGE_CLOUDS_PROFILE)
    model = PCRP.load(None)
    work = Path(tempfile.mkdtemp(prefix='pcrp_robustness_'))
    print('bad clouds, through the node over DDS:', flush=True)
    cases = run_cases(model)
    print('bad depth images as scenes, through the node over DDS:', flush=True)
    scene_cases = run_scene_cases(model)
    print('broken model files, at start-up of the node and the CLI:', flush=True)
    faults = run_faults(default_model_path(), work)
    print('damaged and surprising bags:', flush=True)
    with contextlib.redirect_stdout(io.StringIO()):
        bags = run_bag_faults(work)
    soak = None
    if args.quick:
        soak = soak_mod.run(20.0, 5.0, 2, driver_profile=soak_mod.LARGE_CLOUDS_PROFILE)
    elif args.soak_duration > 0:
        soak = soak_mod.run(args.soak_duration, driver_profile=soak_mod.LARGE_CLOUDS_PROFILE)
    path = write_report(Path(args.out), cases, scene_cases, faults, bags, soak, work, command)
    shutil.rmtree(work, ignore_errors=True)
    print(f'wrote {path}')
    passed = (
        all(ok for _, _, ok in cases)
        and all(ok for _, _, ok in scene_cases)
        and all(all(ok) for _, _, ok in faults)
        and (soak is None or soak['passed'])
    )
    return 0 if passed else 1
