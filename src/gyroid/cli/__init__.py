"""gyroid's command line (click): it parses, calls the library and prints. Bad input ends with
one message and exit code 2; a result that must not be used, exit code 3."""

from __future__ import annotations

import os
import sys
import traceback

import click

from gyroid.cli import (  # noqa: F401  (registers the commands)
    bench_commands,
    export_commands,
    pool_commands,
    roll_commands,
    study_commands,
)
from gyroid.cli.base import cli
from gyroid.errors import GyroidInputError, UntrustworthyResult

__all__ = ["cli", "main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point: run the CLI, turning bad input into one message and exit code 2."""
    try:
        cli.main(args=argv, prog_name="gyroid", standalone_mode=False)
    except GyroidInputError as error:
        click.echo(f"gyroid: error: {error}", err=True)
        return 2
    except UntrustworthyResult:
        return 3
    except click.exceptions.Abort:
        click.echo("gyroid: aborted", err=True)
        return 130
    except click.UsageError as error:  # a bad option or argument: one line, as for bad input
        where = f" (see '{error.ctx.command_path} --help')" if error.ctx is not None else ""
        click.echo(f"gyroid: error: {error.format_message()}{where}", err=True)
        return 2
    except click.ClickException as error:
        error.show()
        return error.exit_code
    except Exception as error:  # an internal fault: short message unless debugging
        if os.environ.get("GYROID_DEBUG"):
            traceback.print_exc()
        click.echo(
            f"gyroid: internal error: {type(error).__name__}: {error} (this is a bug in gyroid;"
            " run again with -v, or set GYROID_DEBUG=1, for the traceback)",
            err=True,
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
