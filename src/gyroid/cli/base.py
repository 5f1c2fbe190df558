"""The command group and what every command shares: option parsing, the --map and prior
options (the self-checks' report: :mod:`gyroid.cli.report`)."""

from __future__ import annotations

from pathlib import Path

import click

from gyroid.cli.report import REPORT_STREAM
from gyroid.errors import GyroidInputError, UntrustworthyResult


class FiniteFloat(click.FloatRange):
    """A float in a range that is a number (click's FloatRange lets nan through)."""

    name = "finite float"

    def convert(self, value, param, ctx):
        import math

        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number", param, ctx)
        return number


#: A random seed: what NumPy's and JAX's generators take.
SEED = click.IntRange(0, 2**32 - 1)
#: A reference temperature, degC.
TEMPERATURE = FiniteFloat(-273.15, 1000.0, min_open=True)
#: A positive number (durations, rates, periods).
POSITIVE = FiniteFloat(0.0, min_open=True)


def parse_assignments(text: str, what: str) -> dict[str, float]:
    values: dict[str, float] = {}
    for item in filter(None, (s.strip() for s in text.split(","))):
        name, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError
            values[name.strip()] = float(value)
        except ValueError:
            raise GyroidInputError(f"{what}: {item!r} is not NAME=NUMBER") from None
    return values


def parse_effects(specs: tuple[str, ...]) -> dict[str, dict[str, float]]:
    effects: dict[str, dict[str, float]] = {}
    for spec in specs:
        name, _, rest = spec.partition(":")
        effects[name.strip()] = parse_assignments(rest, f"--effect {spec}")
    return effects


def map_option(function):
    return click.option(
        "--map", "mappings", multiple=True, metavar="CONTRACT_COLUMN=LOG_COLUMN[:UNIT]",
        help="Read a vendor's column (or a netCDF variable, NAME[AXIS]) as one of "
             "gyroid's (docs/formats.md section 1), converting its unit, e.g. "
             "drift_deg_h=gyro_x:rad/s, temperature_C=temp:K, Hx_uT=mag_x:G, "
             "az_g=acc_z:m/s^2. Repeatable.")(
        function)


def parse_maps(items: tuple[str, ...]):
    from gyroid.io._units import parse_column_maps

    return parse_column_maps(items)


class Command(click.Command):
    """A gyroid command: JAX is configured (float64, the compilation cache) when the command
    runs, not when the command line starts, so that --help and --version stay quick; its
    ``--out`` folder is held for the whole command (a second command writing there at the
    same time is refused before it reads or fits anything); every command takes ``-q`` and
    ``-v`` (what they print: :func:`report_line` and the help of :func:`cli`)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.params += [
            click.Option(["-q", "--quiet"], is_flag=True,
                         help="Print only errors, failed self-checks and the verdict."),
            click.Option(["-v", "--verbose"], is_flag=True,
                         help="Also print the command's wall time, and an internal error's "
                              "traceback (as GYROID_DEBUG=1 does)."),
        ]

    def invoke(self, ctx: click.Context):
        import contextlib
        import io
        import sys
        import time
        import traceback

        from gyroid._config import configure
        from gyroid.io._outputs import output_lock

        quiet, verbose = ctx.params.pop("quiet", False), ctx.params.pop("verbose", False)
        ctx.meta[REPORT_STREAM] = sys.stderr  # failed checks and the verdict, even if quiet
        configure()
        out = ctx.params.get("out")
        started = time.perf_counter()
        with contextlib.ExitStack() as stack:
            if quiet:
                sink = stack.enter_context(io.StringIO())
                stack.enter_context(contextlib.redirect_stdout(sink))
                stack.enter_context(contextlib.redirect_stderr(sink))
            if out is not None:
                stack.enter_context(output_lock(out))
            try:
                return super().invoke(ctx)
            except Exception as error:
                if verbose and not isinstance(error, (click.ClickException,
                                                      GyroidInputError,
                                                      UntrustworthyResult)):
                    traceback.print_exc(file=ctx.meta[REPORT_STREAM])
                raise
            finally:
                if verbose:
                    click.echo(f"{ctx.command_path}: {time.perf_counter() - started:.1f} s",
                               file=ctx.meta[REPORT_STREAM])


class Group(click.Group):
    command_class = Command


Group.group_class = Group


@click.group(cls=Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="gyroid")
def cli() -> None:
    """gyroid: Bayesian identification of gyroscope error models.

    Paper A's FOG drift as a sum of named effects (temperature, its rate, magnetic field and
    candidate effects) and paper B's roll-gyro scale-factor correction: simulate benches and
    flights, fit them (optimistix, then importance sampling or emcee), compensate new runs,
    propagate to the correction coefficient's error, find missing effects, reproduce both
    papers. Start with `gyroid demo`.

    Every command takes -q/--quiet (only errors, failed self-checks and the verdict) and
    -v/--verbose (its wall time, and an internal error's traceback, as GYROID_DEBUG=1
    does). Exit codes: 0 usable, 2 bad input, 3 a self-check says not to use the result, 1
    an internal error (docs/formats.md).
    """


class LazyHelpOption(click.Option):
    """An option whose help text is made only when help is shown (``help_factory``): the
    effect names come from the registry, whose import (JAX) would slow every start."""

    def __init__(self, *args, help_factory, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.help_factory = help_factory

    def get_help_record(self, ctx: click.Context):
        if self.help_factory is not None:
            self.help, self.help_factory = self.help_factory(), None
        return super().get_help_record(ctx)


def terms_option(help_factory=None):
    """``--terms``, its help listing the presets and effects (made when shown)."""
    return click.option("--terms", required=True, metavar="TERMS", cls=LazyHelpOption,
                        help_factory=help_factory or terms_help)


#: The presets, paper A's effects and the candidate effects ``--terms`` lists: the registries
#: of :mod:`gyroid.models` (``PRESETS``, ``EFFECTS``, ``CANDIDATES``; tests/test_cli.py checks
#: they are the same), named here so that ``--help`` imports no JAX (0.6 s of 1.0 s).
TERM_PRESETS = ("thermal", "magnetic", "overload", "full")
PAPER_EFFECTS = ("bias", "temperature", "temperature_sq", "temperature_rate", "magnetic_x",
                 "magnetic_y", "magnetic_z", "overload_x", "overload_y", "overload_z",
                 "overload_sq_x", "overload_sq_y", "overload_sq_z")
CANDIDATE_EFFECTS = ("thermal_lag", "warmup", "time_trend", "magnetic_hysteresis",
                     "bias_step", "thermal_hysteresis", "temperature_cubic")


def terms_help() -> str:
    return (f"Comma list of effects or presets. Presets: {', '.join(TERM_PRESETS)}. Paper "
            f"A's effects: {', '.join(PAPER_EFFECTS)}. Candidates: "
            f"{', '.join(CANDIDATE_EFFECTS)}.")


def prior_options(function):
    function = click.option(
        "--prior", "prior_items", multiple=True, metavar="NAME=normal(MU,SD)",
        help="Override one parameter's prior (normal(MU,SD), lognormal(MEDIAN,LOG_SD) for "
             "time constants and noise levels, or flat()). Repeatable.")(function)
    function = click.option(
        "--priors", "prior_choice", default="default", show_default=True,
        metavar="default|paper_a_fog|flat|FILE.toml",
        help="Prior set: 'default' is weakly informative and scaled to this log (any gyro "
             "grade); 'paper_a_fog' is sized for paper A's FOG; 'flat'; or a TOML file of "
             "NAME = \"normal(MU, SD)\" lines.")(function)
    return function


axes_option = click.option(
    "--axes", "axes", default=None, metavar="AXIS,...",
    help="Gyro axes to fit, e.g. x,y,z (default: every axis the log has, its "
         "drift_AXIS_deg_h columns). With several, OUT holds a folder per axis and "
         "axes.json (docs/formats.md section 5); exit 3 when any axis must not be used.")


instance_option = click.option(
    "--instance", "instance", default=None, type=click.IntRange(0), metavar="N",
    help="A flight-controller or ROS log's IMU, 0 for the first (default): PX4's "
         "sensor_gyro multi_id order, ArduPilot's IMU I, ROS Imu topics in name order.")


def parse_axes(text: str | None) -> tuple[str, ...] | None:
    """``--axes x,y,z`` as a tuple (None: every axis the log has)."""
    if text is None:
        return None
    axes = tuple(dict.fromkeys(item.strip() for item in text.split(",") if item.strip()))
    if not axes:
        raise GyroidInputError(f"--axes {text!r}: name the axes, e.g. --axes x,y,z")
    return axes


#: ``--noise``'s model names: gyroid.inference's NOISE_MODELS and auto, written out here
#: because importing them imports JAX (``--help`` must stay fast); FitOptions checks them.
NOISE_CHOICES = ("auto", "white", "white+gm", "white+flicker+rw")


def fit_options(function):
    """Every option of a bench fit, for ``gyroid fit`` and ``gyroid batch`` alike; the
    command receives them as one checked ``options`` (:class:`gyroid.pipeline.FitOptions`)."""
    import functools

    @functools.wraps(function)
    def wrapper(*args, terms, seed, noise, t0_C, prior_choice, prior_items, flat_prior,
                rate_window, segment_means, mappings, progress, axes, instance, **kwargs):
        from gyroid.bench._options import BenchOptions
        from gyroid.bench._rate_window import parse_rate_window
        from gyroid.models._prior_scales import resolve_prior_option
        from gyroid.noise._model import DEFAULT_NOISE
        from gyroid.pipeline._fit_file import FitOptions, GivenNoisePriors

        prior_set, overrides = resolve_prior_option(prior_choice, prior_items)
        given = None
        if noise not in NOISE_CHOICES:
            if Path(noise).suffix.lower() == ".toml":
                given = GivenNoisePriors.from_datasheet(noise)
            elif Path(noise).is_dir():
                given = GivenNoisePriors.from_noise_fit(noise)
            else:
                raise GyroidInputError(f"--noise {noise!r}: use one of "
                                       f"{', '.join(NOISE_CHOICES)}, a gyro datasheet "
                                       "(FILE.toml), or the --out folder of 'gyroid noise' "
                                       "(no such folder here)")
            noise = DEFAULT_NOISE
        bench = BenchOptions(noise=noise, priors=overrides,
                             prior_set="flat" if flat_prior else prior_set, t0_C=t0_C,
                             rate_window_s=parse_rate_window(rate_window),
                             segment_means=segment_means)
        options = FitOptions(terms=terms, bench=bench, seed=seed, maps=parse_maps(mappings),
                             progress=progress, axes=parse_axes(axes), instance=instance,
                             noise_priors=given)
        return function(*args, options=options, **kwargs)

    for decorate in reversed((
        terms_option(),
        click.option("--seed", default=0, show_default=True, type=SEED,
                     help="Random seed of the sampler."),
        click.option("--noise", default="auto", show_default=True,
                     metavar="|".join(NOISE_CHOICES) + "|FILE.toml|DIR",
                     help="Noise model: white; white plus a Gauss-Markov part; IEEE 952's "
                     "white + flicker (bias instability) + rate random walk; auto: "
                     "white+flicker+rw on every log, B and K with priors that let them be "
                     "negligible; FILE.toml, the gyro's datasheet ([gyro] arw or "
                     "noise_density, bias_instability, rate_random_walk): white+flicker+rw "
                     "with priors about its typical values (a factor of 2 at one sd); or DIR, "
                     "the --out folder of 'gyroid noise' on the same gyro at rest: "
                     "white+flicker+rw with its N, B and K posteriors as priors."),
        click.option("--t0", "t0_C", default=21.0, show_default=True, type=TEMPERATURE,
                     help="Reference temperature t0, degC (t = T - t0)."),
        prior_options,
        click.option("--flat-prior", is_flag=True, help="Same as --priors flat."),
        click.option("--rate-window", "rate_window", default="auto", show_default=True,
                     metavar="auto|SECONDS",
                     help="Window of the dT/dt estimator; auto chooses it from the data."),
        click.option("--segment-means", is_flag=True,
                     help="Burst-sampled log: fit one row per contiguous segment (its "
                          "mean), so the bias's wander between bursts is the estimated "
                          "noise; the samples are still checked for spikes. A noise model "
                          "that carries the wander itself (auto, white+flicker+rw) fits the "
                          "samples and says so in fit.json."),
        map_option,
        axes_option,
        instance_option,
        click.option("--progress/--no-progress", default=True, show_default=True,
                     help="Show the sampler's progress bar."),
    )):
        wrapper = decorate(wrapper)
    return wrapper
