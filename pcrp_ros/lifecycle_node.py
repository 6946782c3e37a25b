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
pcrp_lifecycle_node: the managed (lifecycle) variant of pcrp_node.

It starts unconfigured, with its parameters declared and checked. configure loads and checks
the model and starts the workers; activate subscribes and creates the publishers, so answers
flow; deactivate stops answering and removes them; cleanup stops the workers and frees the
model. A configure that fails (a broken model, settings the model cannot take) is logged and
leaves the node unconfigured. Drive it with `ros2 lifecycle set /pcrp_node configure` and
`activate`, or launch/pcrp_lifecycle.launch.py, which does both.
"""

from __future__ import annotations

import sys

from pcrp_ros.answering import CloudAnswerer
from pcrp_ros.engine import LOAD_ERRORS
from pcrp_ros.node import run
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn


class PcrpLifecycleNode(LifecycleNode):
    """Managed pcrp node; the answering is CloudAnswerer's, as in the plain node."""

    def __init__(self, model=None, node_name: str = 'pcrp_node', on_answer=None, **kwargs):
        """Declare the parameters; model and on_answer as the plain node's (node.py)."""
        super().__init__(node_name, **kwargs)
        # rclpy 7.1 checks a transition asked for by label but not one asked for by id: an id
        # with no transition from the current state (activate while unconfigured) raised
        # RCLError in the service's callback, which ended the executor and the node with it
        change_state = self._service_change_state
        change_state.callback = self._refusing_unavailable_ids(change_state.callback)
        self._given_model = model
        self.answerer = CloudAnswerer(self)
        self.answerer.on_answer = on_answer

    @property
    def model(self):
        engine = self.answerer.engine
        return None if engine is None else engine.model

    @property
    def stats(self):
        return self.answerer.stats

    def _refusing_unavailable_ids(self, change_state):
        """Wrap the change_state service's callback: an unavailable id fails, as a label does."""
        def checked(request, response):
            wanted = request.transition
            if not wanted.label and wanted.id not in {
                    t[0] for t in self._state_machine.available_transitions}:
                state = self._state_machine.current_state[1]
                self.get_logger().warning(f'transition {wanted.id} refused: none from state '
                                          f'{state} has that id')
                response.success = False
                return response
            return change_state(request, response)
        return checked

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        try:
            self.answerer.configure(self._given_model)
        except LOAD_ERRORS as e:
            self.get_logger().error(f'configure failed, still unconfigured: {e}')
            return TransitionCallbackReturn.FAILURE
        return super().on_configure(state)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.answerer.activate()
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.answerer.deactivate()
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.answerer.cleanup()
        return super().on_cleanup(state)

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        self._release()
        return super().on_shutdown(state)

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        self.get_logger().error(f'error in state {state.label}: freeing everything')
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def _release(self) -> None:
        if self.answerer.active:
            self.answerer.deactivate()
        self.answerer.cleanup()

    def destroy_node(self):
        self._release()
        return super().destroy_node()


def main(args=None) -> int:
    return run(PcrpLifecycleNode, 'pcrp_lifecycle_node', args)


if __name__ == '__main__':
    sys.exit(main())
