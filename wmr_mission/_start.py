"""The ``wmr-mission`` program's entry point.

Ctrl-C before the command line is read kills the process as SIGINT does by
default (a shell shows 130), as it does once the program runs
(wmr_mission.cli, ``_command_line_run``): Python's own handler raised a
KeyboardInterrupt inside the imports of the command line and printed their
traceback (3 of 25 stops sent 0.02-0.14 s into ``run``). Set here, in the
program's own first module, not in the package's: a library user's Ctrl-C
stays a KeyboardInterrupt.
"""

import signal

signal.signal(signal.SIGINT, signal.SIG_DFL)


def program() -> None:
    """:func:`wmr_mission.cli.program`."""
    from wmr_mission.cli import program as command_line

    command_line()
