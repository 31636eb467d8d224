"""The one way the suite's executables start, spin and stop (clean exit 0 on SIGINT/SIGTERM)."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node

from tracker_msgs_py.params import ParameterError


class StartupError(RuntimeError):
    """A node cannot start (bad input path, bad parameters...): the message is shown to the user."""


def run_node(make_node: Callable[[], Node], args: Sequence[str] | None = None) -> int:
    """Create the node, spin it until shutdown, and return the process exit code.

    0 after Ctrl-C / SIGTERM or when the node shuts the context down itself; 2 when it cannot start
    (the error is printed once, without a traceback, naming what is wrong).
    """
    rclpy.init(args=args)
    node = None
    try:
        node = make_node()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (StartupError, ParameterError) as error:
        print(f"[FATAL] {error}", file=sys.stderr, flush=True)
        return 2
    except Exception:
        if rclpy.ok():
            raise
        # Ctrl-C landed while the node was still starting to spin: rclpy's handler had already
        # shut the context down, so whatever failed next is part of a requested shutdown.
    finally:
        if node is not None:
            try:
                node.destroy_node()
            except Exception:  # the context may already be gone after a shutdown
                if rclpy.ok():
                    raise
        rclpy.try_shutdown()
    return getattr(node, "exit_code", 0)
