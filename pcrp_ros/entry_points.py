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
The installed commands (setup.py's console_scripts): pcrp, pcrp_node, pcrp_lifecycle_node.

Importing what they need (Open3D, scikit-learn, rclpy) takes about two seconds. A Ctrl-C or
SIGTERM in that time, a launch file stopped as soon as it started, would print Python's
KeyboardInterrupt traceback from the middle of an import, or "ImportError: initialization failed"
from inside a compiled module's. Nothing exists yet that needs cleaning up (ROS is not
initialised, no file is open for writing), so the process ends at once and quietly: with 0 for
a node, as a node stopped later does, and 130 for the command, as shells count an interrupt.
The program's own handling takes over from there: the nodes' when they initialise ROS
(spinning.init_stopping_on_signals), the command's (pcrp_ros.cli) once it is imported.
"""
import importlib
import os
import signal


def pcrp() -> int:
    return _started_quietly('pcrp_ros.cli', 130, restore=True)


def pcrp_node() -> int:
    return _started_quietly('pcrp_ros.node', 0, restore=False)


def pcrp_lifecycle_node() -> int:
    return _started_quietly('pcrp_ros.lifecycle_node', 0, restore=False)


def _started_quietly(module: str, interrupted: int, restore: bool) -> int:
    """
    Import module with a signal ending the process at once, then run its main().

    restore: put Python's handlers back before main() runs; else main() installs its own.
    """
    def end_now(signum, frame):
        os._exit(interrupted)

    # The command leaves a signal it was started ignoring (a background job's Ctrl-C) ignored,
    # as Python does; a node stops on both whatever it inherited, as it will once running.
    handlers = {s: signal.signal(s, end_now) for s in (signal.SIGINT, signal.SIGTERM)
                if not restore or signal.getsignal(s) is not signal.SIG_IGN}
    main = importlib.import_module(module).main
    if restore:
        for s, handler in handlers.items():
            signal.signal(s, handler)
    return main()
