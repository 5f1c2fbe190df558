"""How a command reports a result's self-checks on the console: one line per failed check
(an error in full, a warning's first clause), its entry in docs/checks.md, where its full
text is, the command's options that may mend it; then the verdict, and exit 3 when the
result must not be used."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.errors import UntrustworthyResult

#: ``click.Context.meta`` key of the stream the self-checks are reported on.
REPORT_STREAM = "gyroid.report_stream"


def report_line(line: str) -> None:
    """A line of the self-checks' report: on stderr, also under ``--quiet``."""
    context = click.get_current_context(silent=True)
    stream = context.meta.get(REPORT_STREAM) if context is not None else None
    click.echo(line, file=stream, err=stream is None)


def _current_command() -> str:
    """The command being run, as ``REMEDY_FLAGS`` and ``DOCUMENTED_CHECKS`` name it
    (``fit``, ``roll fit``); empty outside one."""
    context = click.get_current_context(silent=True)
    return " ".join(context.command_path.split()[1:]) if context is not None else ""


def report_axes(result) -> None:
    """Print each axis's failed checks (prefixed by its axis) and a line per axis; exit 3
    when any axis must not be used (every axis's files are written first)."""
    command = _current_command()
    for axis, item in result.results.items():
        for line in check_lines(item.checks, command):
            report_line(f"axis {axis}: {line}")
    for axis, item in result.results.items():
        report_line(f"axis {axis}: {item.checks.verdict()}")
    if not result.trustworthy:
        bad = [axis for axis, item in result.results.items() if not item.trustworthy]
        good = [axis for axis in result.results if axis not in bad]
        which = f"axis {bad[0]}" if len(bad) == 1 else f"axes {', '.join(bad)}"
        report_line(f"{which} must not be used (exit 3)"
                    + (f"; {', '.join(good)} may" if good else ": none of the log's may"))
        raise UntrustworthyResult()


def report_written(result, out: Path, files: tuple[str, ...]) -> None:
    """Say which ``files`` a per-axis command wrote (in ``out``, or in ``out/AXIS/`` for
    every axis with ``axes.json``), then the failed checks, exit 3 when the result (any
    axis) must not be used."""
    if result.several:
        click.echo(f"wrote {', '.join(files)} in {out}/AXIS/ for {', '.join(result.results)}"
                   f" and {out / 'axes.json'}")
        report_axes(result)
        return
    click.echo(f"wrote {', '.join(str(out / name) for name in files)}")
    report_checks(result.only.checks)


_FIT_FLAGS = {"noise_model": "--noise auto", "noise_terms": "--noise white+flicker+rw",
              "segment_means": "--segment-means",
              "discrepancy": "gyroid discrepancy", "prior": "--prior NAME=normal(MU,SD)"}
#: How each command acts on a failed check's remedy codes (a code it cannot act on is only
#: described, in the check's message).
REMEDY_FLAGS = {
    "fit": _FIT_FLAGS, "batch": _FIT_FLAGS, "discrepancy": _FIT_FLAGS,
    "pool": {"noise_model": "--noise auto", "segment_means": "--segment-means",
             "discrepancy": "gyroid discrepancy", "prior": "--prior NAME=normal(MU,SD)"},
    "roll fit": {"discrepancy": "gyroid discrepancy"},
}
_BENCH_CHECKS = {name: name for name in (
    "prior_data_conflict", "point_vs_posterior", "goodness_of_fit", "residual_whiteness",
    "outliers", "identifiability", "convergence", "rate_estimate", "noise_prior_dependence")}
#: Per command, the checks that docs/checks.md has an entry for and that entry's anchor
#: (tests/test_docs.py keeps the two in step): the console names it beside a failed one.
DOCUMENTED_CHECKS: dict[str, dict[str, str]] = {
    "fit": _BENCH_CHECKS, "batch": _BENCH_CHECKS, "discrepancy": _BENCH_CHECKS,
    "compensate": {name: f"compensate-{name}" for name in (
        "extrapolation", "compensation_gain", "fit_trustworthy", "predictive", "window_bands",
        "turn_on_bias", "units")},
    "pool": _BENCH_CHECKS | {name: f"pool-{name}" for name in (
        "run_consistency", "between_run_sd_identified")},
    "noise": {name: f"noise-{name}" for name in (
        "outliers", "prefilter", "level_fit", "level_runs", "dispersion", "allan_interval")} | {
        name: name for name in ("convergence", "point_vs_posterior", "prior_data_conflict")},
}


#: Where each command writes its checks' full text.
RESULT_FILES = {"fit": "fit.json", "batch": "fit.json", "compensate": "compensate.json",
                "pool": "pool.json", "noise": "noise.json", "roll fit": "roll_fit.json",
                "discrepancy": "discrepancy.json"}
#: A check's message longer than this is cut, in the console, at its first clause ...
CONSOLE_MESSAGE = 160
#: ... if that clause is no longer than this.
CLAUSE_AT_MOST = 240


def first_clause(message: str, limit: int = CONSOLE_MESSAGE) -> str:
    """``message`` as is when it is at most ``limit`` characters, else up to its first
    ``: `` or ``; `` outside parentheses (what was found; the rest says why and what to
    do) if that is within :data:`CLAUSE_AT_MOST`, else up to the last space before
    ``limit`` (before a parenthesis still open there)."""
    if len(message) <= limit:
        return message
    depth, opened, open_at_limit = 0, -1, -1  # where the outermost parenthesis opened
    for i, char in enumerate(message[:CLAUSE_AT_MOST]):
        if char == "(" and depth == 0:
            opened = i
        depth += (char == "(") - (char == ")")
        if i == limit and depth > 0:
            open_at_limit = opened
        if depth == 0 and char in ":;" and message[i + 1:i + 2] == " " and i >= 20:
            return message[:i]
    if open_at_limit > 20:  # not inside a parenthesis: before it
        return message[:open_at_limit].rstrip()
    space = message.rfind(" ", 0, limit)
    return message[:space] if space > 0 else message[:limit]


def check_lines(checks, command: str) -> list[str]:
    """One line per failed check (errors first): an error's message, a warning's first
    clause (:func:`first_clause`) and where its full text is; each with its entry in the
    documentation's check table where it has one and the options of ``command`` that act
    on its remedies."""
    flags = REMEDY_FLAGS.get(command, {})
    anchors = DOCUMENTED_CHECKS.get(command, {})
    where = RESULT_FILES.get(command, "the result file")
    lines = []
    for check in sorted(checks.failed, key=lambda c: c.severity != "error"):
        tries = [flags[code] for code in check.remedies if code in flags]
        hint = f" (try: {'; '.join(tries)})" if tries else ""
        anchor = anchors.get(check.name)
        entry = f" [docs/checks.md#{anchor}]" if anchor else ""
        # an error (the result must not be used) in full; a warning in one line
        text = check.message if check.severity == "error" else first_clause(check.message)
        more = f" ... (in full: {where})" if text != check.message else ""
        lines.append(f"{check.severity}: {check.name}{entry}: {text}{more}{hint}")
    return lines


def report_checks(checks) -> None:
    """Print every failed self-check in one line (with this command's options for its
    remedies), then the verdict; exit 3 when the result must not be used (outputs are
    written first)."""
    command = _current_command()
    for line in check_lines(checks, command):
        report_line(line)
    if not checks.trustworthy:
        report_line(checks.verdict())
        raise UntrustworthyResult()
