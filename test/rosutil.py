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

"""Running the node for real over DDS inside a test: own ROS domain, own executor thread."""
import os

# a domain of our own, so parallel runs and other ROS processes on the machine stay apart
os.environ.setdefault('ROS_DOMAIN_ID', str(100 + os.getpid() % 100))
os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

from pcrp_ros.spinning import ros_context, spinning, wait_for  # noqa: E402,F401


def own_domain_env(offset: int) -> dict:
    """Return this process's environment with a ROS domain offset from the tests' own."""
    domain = (int(os.environ['ROS_DOMAIN_ID']) + offset) % 200 + 1
    return {**os.environ, 'ROS_DOMAIN_ID': str(domain)}


def publish_until(pub, msg, predicate, timeout=60.0, every=3.0):
    """
    Publish msg, again every `every` seconds, until predicate holds.

    Matching is not symmetric: the publisher may see the subscription before the subscriber has
    seen the publisher, and a best-effort first message is then lost; a busy machine widens that
    gap.
    """
    import time
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        pub.publish(msg)
        if wait_for(predicate, min(every, end - time.monotonic())):
            return True
    return False


def lines_until(stream, done, timeout=60.0) -> list[str]:
    """
    Read lines from a subprocess's output until one satisfies done (then the last), or it ends.

    Whatever DDS prints at start-up (a stale shared-memory port, say) may come before the line a
    test waits for. The timeout is looked at between lines only.
    """
    import time
    end, lines = time.monotonic() + timeout, []
    while time.monotonic() < end:
        line = stream.readline()
        if not line:
            break
        lines.append(line)
        if done(line):
            break
    return lines
