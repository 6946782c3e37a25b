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
pcrp_node: segmented object clouds in; gallery ID, pose and the aligned model out.

Per input topic T: T/pose (PoseStamped), T/gallery_id (String), T/aligned_model (PointCloud2)
and, where vision_msgs is installed, T/detections (Detection3DArray); all carry the input's
header unchanged. The work is done by pcrp_ros.answering.CloudAnswerer, which this node
configures and activates at once; pcrp_lifecycle_node is the managed variant of the same.
"""

from __future__ import annotations

import faulthandler
import signal
import sys

from pcrp_core import ModelError
from pcrp_ros.answering import CloudAnswerer
from pcrp_ros.spinning import init_stopping_on_signals, node_executor, spin_until_interrupted
from pcrp_ros.workers import WorkerStartError
import rclpy
from rclpy.exceptions import NameValidationException, ParameterException
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

# what stops a node at start-up with one line: a broken model, a mistyped parameter or topic
START_ERRORS = (ModelError, ValueError, ParameterException, NameValidationException,
                WorkerStartError)


class PcrpNode(Node):
    """The plain node: loads its model and answers from the moment it is made."""

    def __init__(self, model=None, node_name: str = 'pcrp_node', on_answer=None, **kwargs):
        """
        Load the model (a PCRP, or None: model_path's) and start answering.

        on_answer: told (topic, header, PoseResult) of every estimate (pcrp_ros/answering.py).
        """
        super().__init__(node_name, **kwargs)
        self.answerer = CloudAnswerer(self)
        self.answerer.on_answer = on_answer
        self.answerer.configure(model)
        try:
            self.answerer.activate()
        except BaseException:
            self.answerer.cleanup()
            raise

    @property
    def model(self):
        """Return the model answering now (it changes when model_path is set)."""
        return self.answerer.engine.model

    @property
    def stats(self):
        return self.answerer.stats

    def destroy_node(self):
        self.answerer.deactivate()
        self.answerer.cleanup()
        return super().destroy_node()


def run(make_node, program: str, args=None) -> int:
    """Spin the node make_node() returns until Ctrl-C; 1 with one line on a start-up error."""
    # a crash inside DDS or Open3D prints the Python stack of every thread, and `kill -USR1 <pid>`
    # prints them on demand (what a stuck node is doing), instead of dying or hanging silently
    faulthandler.enable(all_threads=True)
    if hasattr(signal, 'SIGUSR1'):
        faulthandler.register(signal.SIGUSR1, all_threads=True)
    # Ctrl-C and SIGTERM stop the executor only; the node is destroyed before the context
    init_stopping_on_signals(args)
    # The executor exists before the node says it is listening: a Ctrl-C that lands while an
    # executor is being built leaves a half-made object whose __del__ prints a traceback. Several
    # threads: ~/reload_model waits for the new model while clouds keep arriving.
    executor = node_executor()
    node = None
    try:
        node = make_node()
        executor.add_node(node)
        spin_until_interrupted(executor)
    except START_ERRORS as e:
        print(f'{program}: error: {e}', file=sys.stderr)
        return 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # Something else shut the context down (rclpy.shutdown() elsewhere in the process): if
        # that lands between the executor's check of the context and its making the next wait
        # set, rcl refuses the wait set (RCLError, a RuntimeError) instead of the executor
        # stopping. Anything raised while the context is still up is a real failure.
        if rclpy.ok():
            raise
    finally:
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


def main(args=None) -> int:
    return run(PcrpNode, 'pcrp_node', args)


if __name__ == '__main__':
    sys.exit(main())
