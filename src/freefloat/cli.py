"""The ``freefloat`` command line (typer): ``freefloat COMMAND ...`` or ``python -m freefloat COMMAND ...``.

A thin layer over the library: each command resolves its inputs, calls
library functions, and prints or writes their results. Shared rules:

- MODEL is a ``.toml`` / ``.urdf`` path or a built-in name (:data:`freefloat.models.BUILTIN_MODELS`),
  read by :func:`freefloat.models.load_model`.
- Bad input (a :class:`~freefloat.FreefloatError`, ``ValueError`` or ``OSError``
  such as a missing file) prints ONE line ``error: <message>`` on stderr and
  exits with code 1; no traceback.
- Files the user names as input are only read. ``--out`` directories are
  created; a run never replaces a file there unless ``--overwrite`` is given,
  and then only the files freefloat itself wrote earlier, unchanged
  (``DIR/freefloat-manifest.json``, :mod:`freefloat.io.outputs`). ``--out ""`` is an error.
- Warnings (model corrections, stiff gains, long runs, near-singular plans, ...) print as one ``warning: ...`` line
  each on stderr, for every command (:func:`_warnings_as_lines`, entered by the app's callback); the user's own
  filters decide first (``python -W error -m freefloat ...`` or ``PYTHONWARNINGS=error``: one ``error:`` line, exit 1).

New commands register on :data:`app` with ``@app.command("name")`` and wrap
their body in ``with user_errors():``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from .analysis.singularity import jacobian_determinant_map
from .core.errors import FreefloatError, ModelError, UnknownNameError
from .core.model import Model
from .io.outputs import OutputDirectory, check_targets, output_directory, staged_outputs
from .models import BUILTIN_MODELS, load_model
from .papers.paper_report import report_summary
from .papers.report import PAPER_PAYLOAD, model_info, paper_systems, render_text, write_model_reports

__all__ = ["app", "criterion_options", "main", "output_dir", "user_errors", "with_payload"]

app = typer.Typer(
    name="freefloat",
    help="Kinematics, dynamics and workspaces of space robots (Papadopoulos & Dubowsky 1991, Papadopoulos 1992).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # plain help: "[singularity]" stays as written, and flags show no "<bool>" type
)


# --------------------------------------------------------------------- shared pieces
@contextmanager
def user_errors() -> Iterator[None]:
    """Turn bad input into one ``error: ...`` line on stderr and exit code 1 (warnings, model corrections among them, are
    the app's: :func:`_warnings_as_lines` shows each as it happens, so a correction is reported before the error)."""
    try:
        yield
    except (FreefloatError, OSError, ValueError, Warning) as exc:  # a Warning: one the user's -W error made an error
        message = " ".join(str(exc).split()) or type(exc).__name__
        typer.echo(f"error: {message}", err=True)
        raise typer.Exit(1) from None
    except MemoryError as exc:  # a last resort: the calls check their memory before they take it
        typer.echo(f"error: out of memory ({' '.join(str(exc).split())}); ask for less: fewer samples, states or trajectories", err=True)
        raise typer.Exit(1) from None


def _inertia(text: str) -> Any:
    try:
        values = [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        raise ValueError(f"--payload-inertia: cannot read {text!r} as numbers; give I (kg m²), Ixx,Iyy,Izz, or 9 numbers") from None
    if len(values) == 1:
        return values[0]
    if len(values) == 3:
        return values
    if len(values) == 9:
        return np.reshape(values, (3, 3))
    raise ValueError(f"--payload-inertia: expected 1, 3 or 9 numbers, got {len(values)}")


_PAYLOAD_OPTIONS = {"mass": "--payload-mass", "inertia": "--payload-inertia"}


def with_payload(model: Model, mass: float | None, inertia: str | None, end_effector: str | None) -> Model:
    """Apply the ``--payload-*`` options: the model after capturing a payload, or the model unchanged.
    Errors name the option (``--payload-mass: must be positive ...``), not the API's field."""
    if mass is None:
        if inertia is not None or end_effector is not None:
            raise ValueError("--payload-inertia and --payload-ee need --payload-mass")
        return model
    if inertia is None:
        raise ValueError("--payload-mass needs --payload-inertia (kg m² about the payload CM: I, or Ixx,Iyy,Izz)")
    ee: str | int = 0
    if end_effector is not None:
        ee = int(end_effector) if end_effector.isdigit() and end_effector not in model.end_effector_names else end_effector
    try:
        return model.with_payload(end_effector=ee, mass=mass, inertia=_inertia(inertia))
    except UnknownNameError as exc:
        raise ValueError(f"--payload-ee: {exc}") from None
    except ModelError as exc:
        option = _PAYLOAD_OPTIONS.get(exc.field.rsplit(".", 1)[-1])
        if option is None:
            raise
        raise ModelError(option, exc.problem, exc.fix) from None


def output_dir(path: Path) -> Path:
    """Create the ``--out`` directory (and its parents); refuse an empty path or a path that is a file."""
    return output_directory(path)


class _EmptyPath(type(Path())):  # type: ignore[misc]
    """``--out ""``: kept apart from ``--out .`` so that the command can refuse it with one clear line."""


def _out_path(value: str) -> Path:
    return _EmptyPath("") if not str(value).strip() else Path(value)  # ~ expanded by freefloat.io.outputs


def _user_path(value: str) -> Path:
    """A path argument (SCENARIO) with ``~`` expanded, as a shell does where the user quoted it."""
    return Path(os.path.expanduser(value))


@contextmanager
def _staged(out: Path, overwrite: bool, command: str) -> Iterator[OutputDirectory]:
    """The ``--out`` directory of a command, written through a staging folder (never clobbers)."""
    if isinstance(out, _EmptyPath):
        output_directory("")
    with staged_outputs(out, overwrite=overwrite, command=command) as target:
        yield target


@contextmanager
def _optional_out(out: Path | None, overwrite: bool, command: str, names: list[str]) -> Iterator[OutputDirectory | None]:
    """``_staged`` for an optional ``--out`` (None: no output folder), entered before the work: a folder that cannot
    be made, or files of an earlier run among ``names``, are refused before anything is computed."""
    if out is None:
        yield None
        return
    if not isinstance(out, _EmptyPath):
        check_targets(out, names, overwrite=overwrite)
    with _staged(out, overwrite, command) as target:
        yield target


@contextmanager
def _warnings_as_lines() -> Iterator[None]:
    """Show warnings as one ``warning: ...`` line each on stderr, when they happen, without Python's source path and line
    number: every ``UserWarning`` (freefloat's own classes: corrections, stiff gains, long runs, near-singular plans, a
    damaged cache or store; and those of other libraries), each distinct message once; other categories as Python's
    filters decide (a library's DeprecationWarning stays hidden). Entered for every command by the app's callback.

    The user's filters come first: ``python -W error -m freefloat ...`` or ``PYTHONWARNINGS=error`` turn a warning
    into an error (one ``error: ...`` line and exit 1, :func:`user_errors`), ``-W ignore::UserWarning`` hides them; the
    "always" added here is appended after them and decides only for the warnings no filter of theirs names."""
    with warnings.catch_warnings():
        warnings.filterwarnings("always", category=UserWarning, append=True)
        previous = warnings.showwarning
        shown: set[tuple[type, str]] = set()

        def show(message: Any, category: Any, filename: str, lineno: int, file: Any = None, line: Any = None) -> None:
            text = " ".join(str(message).split()) or category.__name__
            if (category, text) not in shown:
                shown.add((category, text))
                typer.echo(f"warning: {text}", err=True)

        warnings.showwarning = show
        try:
            yield
        finally:
            warnings.showwarning = previous


def _version(value: bool) -> None:
    if value:
        from . import __version__

        typer.echo(f"freefloat {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    ctx: typer.Context,
    version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")] = False,
) -> None:
    """Kinematics, dynamics and workspaces of space robots (Papadopoulos & Dubowsky 1991, Papadopoulos 1992)."""
    ctx.with_resource(_warnings_as_lines())  # for the whole command: its warnings as `warning: ...` lines


# --------------------------------------------------------------------- commands
ModelArg = Annotated[
    str,
    typer.Argument(metavar="MODEL", help=f"A .toml, .urdf or MJCF .xml model file, or a built-in model: {', '.join(BUILTIN_MODELS)}."),
]
PayloadMass = Annotated[
    float | None, typer.Option("--payload-mass", metavar="KG", help="Inspect the model after capturing a payload of this mass (kg).")
]
PayloadInertia = Annotated[
    str | None,
    typer.Option(
        "--payload-inertia",
        metavar="I",
        help="Payload inertia about its CM (kg m²): I (isotropic; Izz for planar models), Ixx,Iyy,Izz, or 9 numbers.",
    ),
]
PayloadEE = Annotated[
    str | None, typer.Option("--payload-ee", metavar="NAME", help="End effector (name or index) that holds the payload; default the first.")
]


EndEffectorOption = Annotated[
    list[str] | None,
    typer.Option(
        "--end-effector",
        "-e",
        metavar="NAME",
        help="An end effector of a model file: a link/body/site name (repeat for several); replaces the file's or the scenario's. "
        "Default: those the file (or scenario) names, else every leaf.",
    ),
]
StrictOption = Annotated[
    bool, typer.Option("--strict", help="Refuse non-physical inertias in URDF/MJCF files instead of correcting them (with a warning).")
]


RowsOpt = Annotated[
    str | None,
    typer.Option(
        "--rows",
        metavar="ROWS",
        help="Rows of J* that decide singularity: position (translational), full, or auto (the paper's: all 6 in 3D).",
    ),
]
MeasureOpt = Annotated[
    str | None,
    typer.Option(
        "--measure", metavar="MEASURE", help="Singularity measure: sigma_min (smallest singular value), manipulability, det, or auto."
    ),
]
ThresholdOpt = Annotated[
    float | None, typer.Option("--threshold", metavar="VALUE", help="Singular where |measure| <= this (default 0: exact singularities).")
]


def criterion_options(rows: str | None, measure: str | None, threshold: float | None, base: Any = None) -> Any:
    """A SingularityCriterion from ``--rows/--measure/--threshold``, each overriding ``base`` (default: the paper's)."""
    from .analysis.singularity import SingularityCriterion

    base = base if base is not None else SingularityCriterion()
    return SingularityCriterion(
        rows=base.rows if rows is None else rows,
        measure=base.measure if measure is None else measure,
        threshold=base.threshold if threshold is None else threshold,
    )


Overwrite = Annotated[
    bool,
    typer.Option(
        "--overwrite",
        help="Replace files of an earlier freefloat run in --out (only those listed in its freefloat-manifest.json and unchanged).",
    ),
]


@app.command("inspect")
def inspect_command(
    model: Annotated[
        str | None,
        typer.Argument(
            metavar="[MODEL]",
            help="A .toml, .urdf or MJCF .xml model file, or a built-in model; without MODEL, list the built-in models (the zoo).",
        ),
    ] = None,
    json_output: Annotated[bool, typer.Option("--json", help="Print one JSON object instead of text.")] = False,
    end_effector: EndEffectorOption = None,
    strict: StrictOption = False,
    payload_mass: PayloadMass = None,
    payload_inertia: PayloadInertia = None,
    payload_ee: PayloadEE = None,
) -> None:
    """Print a model: joints, end effectors (and the rule that chose them), mass properties, barycentric
    vectors (1992 eqs. 5-9) and every correction made when loading it; without MODEL, list the built-in models."""
    with user_errors():
        if model is None:
            listing = [{"name": name, "description": text} for name, (text, _) in BUILTIN_MODELS.items()]
            if json_output:
                typer.echo(json.dumps({"models": listing}, indent=2))
            else:
                width = max(len(m["name"]) for m in listing)
                typer.echo("built-in models (freefloat inspect NAME for one; provenance in docs/model-files.md):")
                for m in listing:
                    typer.echo(f"  {m['name'].ljust(width)}  {m['description']}")
            return
        loaded = load_model(model, end_effectors=end_effector or None, strict=strict)
        info = model_info(with_payload(loaded, payload_mass, payload_inertia, payload_ee))
    typer.echo(json.dumps(info, indent=2) if json_output else render_text(info).rstrip("\n"))


@app.command("specialise")
def specialise_command(
    model: ModelArg,
    kind: Annotated[
        list[str] | None,
        typer.Option(
            "--kind",
            metavar="KIND",
            help="jstar (J* batches), rollout (RK4 rollouts), hplus (H+), forward or inverse (dynamics), "
            "measure (det J*, sigma_min, manipulability, condition); repeatable (default: all).",
        ),
    ] = None,
    end_effector: EndEffectorOption = None,
    strict: StrictOption = False,
) -> None:
    """Compile the specialised kernels (J*, rollouts, H+, dynamics, measures) for the structure of MODEL, once per machine
    (seconds per kind), for sweeps and campaigns: later large batches and rollouts of this robot, in every process, run
    several times faster (docs/performance.md)."""
    from .mechanics.specialised import KINDS, specialise

    with user_errors():
        loaded = load_model(model, end_effectors=end_effector or None, strict=strict)
        took = specialise(loaded, kind or KINDS, progress=lambda k: typer.echo(f"specialising {k} ...", err=True))
    for k, seconds in took.items():
        typer.echo(f"{k}: ready in {seconds:.1f} s (compiled once per machine; loaded from the cache afterwards)")


DETJ_MAP_PNG = "detJ_map_1992_one_arm_captured.png"
#: ``freefloat simulate`` asks for confirmation (or --yes) before a run estimated to take longer (s).
LONG_RUN_S = 60.0


@app.command("kernels")
def kernels_command(
    compile_now: Annotated[
        bool,
        typer.Option("--compile", help="Compile this machine's own kernels now (what a new user's first calls need: minutes, once)."),
    ] = False,
    json_output: Annotated[bool, typer.Option("--json", help="Print one JSON object instead of text.")] = False,
) -> None:
    """Say where the engine's compiled kernels come from on this machine: its own cache, or the portable kernels
    shipped with freefloat (for any CPU of its kind, up to about 2.5x slower) while its own compile in the background
    (FREEFLOAT_KERNELS: auto, portable or native; docs/performance.md)."""
    from .engine import kernel_status

    with user_errors():
        if compile_now:
            import time

            from . import warmup

            start = time.perf_counter()
            typer.echo("compiling this machine's kernels (minutes, once) ...", err=True)
            with _env(KERNELS="native"):
                warmup.main([])
            typer.echo(f"compiled or loaded in {time.perf_counter() - start:.0f} s", err=True)
        status = kernel_status()
    if json_output:
        typer.echo(json.dumps(status, indent=2))
        return
    manifest = status["manifest"]
    typer.echo(f"setting: FREEFLOAT_KERNELS={status['setting']}")
    typer.echo(f"this machine's kernels: {status['native']} compiled in {status['folder']} (background compile: {status['background']})")
    if status["portable"]:
        built = f"numba {manifest['numba']}, Python {manifest['python']}, {manifest['triple']}"
        typer.echo(f"portable kernels: {manifest['kernels']} for {built}, in {status['portable']}")
    else:
        typer.echo(f"portable kernels: not used ({status['portable_note'] or 'FREEFLOAT_KERNELS=native'})")


@contextlib.contextmanager
def _env(**values: str) -> Iterator[None]:
    """``FREEFLOAT_<NAME>=value`` for the duration (the child processes inherit it)."""
    names = {f"freefloat_{name}".upper(): value for name, value in values.items()}
    before = {name: os.environ.get(name) for name in names}
    os.environ.update(names)
    try:
        yield
    finally:
        for name, value in before.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


@app.command("demo")
def demo_command(
    out: Annotated[Path, typer.Option("--out", parser=_out_path, metavar="DIR", help="Output directory (created).")] = Path("out"),
    overwrite: Overwrite = False,
) -> None:
    """The main job: reproduce both papers (OUT/1991/, OUT/1992/: report.json, report.md, figures), write
    reports of the papers' systems (OUT/models/) and the det J* map of the captured one-arm system."""
    from matplotlib.figure import Figure

    from .papers.reproduce import output_names

    with user_errors():
        systems = paper_systems()
        known = [f"{p}/{name}" for p in ("1991", "1992") for name in output_names(p)]
        known += [f"models/{slug}.{ext}" for slug, _, _ in systems for ext in ("json", "md")]
        if not isinstance(out, _EmptyPath):
            check_targets(out, [*known, "models/report.md", DETJ_MAP_PNG, "README.md"], overwrite=overwrite)  # before the work
    with user_errors(), _staged(out, overwrite, "demo") as target:
        out = target.stage
        mass, inertia = PAPER_PAYLOAD
        written = write_model_reports(
            systems,
            out / "models",
            title="freefloat: the systems of Papadopoulos & Dubowsky 1991 and Papadopoulos 1992",
            preamble=(
                "Written by `freefloat demo`; one section per system, the same content as `freefloat inspect MODEL`.",
                "",
                f"![det J* map of the 1992 one-arm system after capture](../{DETJ_MAP_PNG})",
            ),
        )
        captured = next(model for slug, _, model in systems if slug == "papadopoulos1992_one_arm_captured")
        dmap = jacobian_determinant_map(captured, (0, 1), n=361)
        fig = Figure(figsize=(6.4, 5.6), layout="constrained")
        ax = fig.add_subplot()
        dmap.plot(ax)
        ax.set_title(
            f"1992 one-arm system after capturing the payload ({mass:g} kg, {inertia:g} kg m²)\n"
            "dynamic singularities: det ⁰J*(q) = 0 (1992 eq. 17)",
            fontsize="medium",
        )
        png = out / DETJ_MAP_PNG
        fig.savefig(png, dpi=200)
        written.append(png)
        from .papers.reproduce import reproduce_1991, reproduce_1992

        for paper, reproduce in (("1991", reproduce_1991), ("1992", reproduce_1992)):
            typer.echo(f"reproducing {paper} into {target.path / paper} ...", err=True)
            written += reproduce(output_dir(out / paper))
        written.append(_write_demo_index(out, written))
    for path in target.final(written):
        typer.echo(str(path))


def _write_demo_index(out: Path, written: list[Path]) -> Path:
    """OUT/README.md: what `freefloat demo` wrote, with the paper-vs-freefloat summary of each report."""
    lines = ["# freefloat demo output", "", "Written by `make demo` (`freefloat demo --out OUT`).", ""]
    for paper in ("1991", "1992"):
        n_rows, compared, agree = report_summary(json.loads((out / paper / "report.json").read_text())["rows"])
        lines.append(
            f"- [{paper}/report.md]({paper}/report.md): {n_rows} rows, {compared} with a printed number, "
            f"{agree} agree at the printed precision (the others are explained row by row)."
        )
    lines.append("- [models/](models/): the papers' systems, as `freefloat inspect` prints them.")
    lines += ["", "Files:", ""] + [f"- `{p.relative_to(out)}`" for p in written if p.is_relative_to(out)]
    index = out / "README.md"
    index.write_text("\n".join(lines) + "\n")
    return index


@app.command("workspace")
def workspace_command(
    model: ModelArg,
    arm: Annotated[
        list[str] | None,
        typer.Option("--arm", metavar="NAME", help="End effector (name or index) to analyse; repeat for several. Default: all."),
    ] = None,
    payload_mass: PayloadMass = None,
    payload_inertia: PayloadInertia = None,
    payload_ee: PayloadEE = None,
    piw: Annotated[
        bool | None, typer.Option("--piw/--no-piw", help="Compute the PIW/PDW (eq. 17). Default: only when J* is square.")
    ] = None,
    samples: Annotated[int, typer.Option("--samples", min=16, metavar="N", help="Configurations sampled for the PIW.")] = 1 << 16,
    out: Annotated[
        Path | None,
        typer.Option("--out", parser=_out_path, metavar="DIR", help="Write workspace.json and one plot per end effector here (created)."),
    ] = None,
    json_output: Annotated[bool, typer.Option("--json", help="Print one JSON object instead of the table.")] = False,
    rows: RowsOpt = None,
    measure: MeasureOpt = None,
    threshold: ThresholdOpt = None,
    overwrite: Overwrite = False,
    end_effector: EndEffectorOption = None,
    strict: StrictOption = False,
) -> None:
    """Workspace limits about the system CM (1992 eqs. 15-17): reachable, guaranteed, PIW/PDW, with method and accuracy.

    -e names the model file's end effectors (J* has 6 rows per end effector: name the tools, not every leaf);
    --arm picks the ones to analyse among them."""
    from .analysis.workspace_report import limits_json, workspace_limits, write_workspace_plots

    with user_errors():
        if isinstance(out, _EmptyPath):
            output_directory("")  # refused before the work
        loaded = with_payload(
            load_model(model, end_effectors=end_effector or None, strict=strict), payload_mass, payload_inertia, payload_ee
        )
        names = loaded.end_effector_names
        chosen = [int(a) if a.isdigit() and a not in names else a for a in arm or []]
        criterion = criterion_options(rows, measure, threshold)
        written: list[Path] = []
        with _optional_out(out, overwrite, "workspace", ["workspace.json"]) as target:
            limits = workspace_limits(loaded, chosen or None, piw=piw, samples=samples, criterion=criterion)
            if target is not None:
                (target.stage / "workspace.json").write_text(limits_json(limits) + "\n")
                written = [target.stage / "workspace.json", *write_workspace_plots(limits, target.stage)]
        written = target.final(written) if target is not None else []
    typer.echo(limits_json(limits) if json_output else limits.render_text().rstrip("\n"))
    for path in written:
        typer.echo(f"wrote {path}", err=True)


@app.command("capture")
def capture_command(
    scenario: Annotated[
        Path, typer.Argument(metavar="SCENARIO", parser=_user_path, help="Capture scenario TOML (schema: docs/workspaces.md).")
    ],
    out: Annotated[
        Path | None, typer.Option("--out", parser=_out_path, metavar="DIR", help="Write capture.json and the plots here (created).")
    ] = None,
    overwrite: Overwrite = False,
    rows: RowsOpt = None,
    measure: MeasureOpt = None,
    threshold: ThresholdOpt = None,
    strategy: Annotated[
        str | None,
        typer.Option(
            "--strategy",
            metavar="STRATEGY",
            help="auto (PIW, else a path-checked plan), piw (the paper's) or path; overrides the scenario.",
        ),
    ] = None,
    rank_by: Annotated[
        str | None,
        typer.Option(
            "--rank-by",
            metavar="CRITERION",
            help="How the capture posture of a moving target is chosen: measure (1992 §V), spacecraft_rate, impulse, "
            "angular_impulse or joint_impulse (locked joints); overrides the scenario's [grasp] rank_by.",
        ),
    ] = None,
    end_effector: EndEffectorOption = None,
    no_animation: Annotated[
        bool,
        typer.Option("--no-animation", help="With a [detumble] table and --out: skip the GIF of the detumbling run."),
    ] = False,
    yes: Annotated[
        bool,
        typer.Option("--yes", "-y", help=f"Run without asking even when the capture sequence is estimated over {LONG_RUN_S:g} s."),
    ] = False,
) -> None:
    """Plan a payload capture (1992 §V): approach distance, CM+, R+, capture posture and spacecraft orientation.

    --rows/--measure/--threshold/--strategy override the scenario's [singularity] table. A moving target (the
    scenario's [payload] velocity, angular_velocity): the impact at the grasp and the candidate postures ranked;
    with a [detumble] table, the capture sequence (the grasp, then detumbling) is simulated and reported. Its run is
    estimated first, as `freefloat simulate` estimates its runs: one expected to take over a minute asks for
    confirmation (--yes skips it)."""
    import sys

    from .analysis._capture_ranking import grasp_problem
    from .analysis.capture import STRATEGIES
    from .scenarios.capture_scenario import estimate_capture_sequence, load_capture_scenario, run_capture_scenario, write_capture_outputs
    from .scenarios.capture_sequence import ANIMATION_FILE, SEQUENCE_FILES
    from .scenarios.capture_settings import check_sequence_estimate

    with user_errors():
        if out is not None and isinstance(out, _EmptyPath):
            output_directory("")
        loaded = load_capture_scenario(scenario, end_effectors=end_effector or None)
        if strategy is not None and strategy not in STRATEGIES:
            raise ValueError(f"--strategy {strategy!r}: unknown; choose one of {', '.join(STRATEGIES)}")
        moving = loaded.velocity is not None or loaded.angular_velocity is not None
        if rank_by is not None:
            broken = grasp_problem(moving, loaded.joints, rank_by)
            if broken is not None:
                raise ValueError(f"--rank-by {rank_by!r}: {broken[1]}; {broken[2]}")
        loaded = dataclasses.replace(
            loaded,
            criterion=criterion_options(rows, measure, threshold, loaded.criterion),
            strategy=loaded.strategy if strategy is None else strategy,
            rank_by=loaded.rank_by if rank_by is None else rank_by,
        )
        written: list[Path] = []
        names = ["capture.json", "capture_plan.png", *(["capture_tradeoff.png"] if moving else [])]
        if loaded.detumble is not None:
            names += [*SEQUENCE_FILES, *([] if no_animation else [ANIMATION_FILE])]
        if out is not None and not isinstance(out, _EmptyPath):  # before the estimate and its question, as simulate checks
            check_targets(out, names, overwrite=overwrite)
        estimate = estimate_capture_sequence(loaded)
        if estimate is not None:  # before the plan, as simulate's before its run
            check_sequence_estimate(estimate, None)
            typer.echo(f"{loaded.source}: the capture sequence: {estimate.describe()}", err=True)
            if estimate.seconds > LONG_RUN_S and not yes:
                if not sys.stdin.isatty():
                    raise ValueError(
                        f"the capture sequence is estimated to take over {LONG_RUN_S:g} s ({estimate.describe()}); pass --yes to run it"
                    )
                typer.confirm(f"The capture sequence is estimated to take over {LONG_RUN_S:g} s. Run it?", abort=True, err=True)
        with _optional_out(out, overwrite, "capture", names) as target:
            result = run_capture_scenario(loaded, warn_after=None)
            if target is not None:
                written = write_capture_outputs(result, target.stage, animation=not no_animation)
        written = target.final(written) if target is not None else []
    typer.echo(result.render_text().rstrip("\n"))
    for path in written:
        typer.echo(f"wrote {path}", err=True)


@app.command("simulate")
def simulate_command(
    scenario: Annotated[
        Path, typer.Argument(metavar="SCENARIO", parser=_user_path, help="Simulation scenario TOML (schema: docs/simulation.md).")
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out", parser=_out_path, metavar="DIR", help="Output directory (created): trajectory .npz/.csv/.json and .png plots."
        ),
    ] = Path("out"),
    progress: Annotated[
        bool | None,
        typer.Option(
            "--progress/--no-progress",
            help="Progress on stderr (default: a bar on a terminal once the run has lasted 2 s; elsewhere a line every 10 s).",
        ),
    ] = None,
    animate: Annotated[
        Path | None,
        typer.Option("--animate", metavar="PATH", help="Also write an animation of the motion: .gif (Pillow) or .mp4 (ffmpeg)."),
    ] = None,
    overwrite: Overwrite = False,
    yes: Annotated[
        bool, typer.Option("--yes", "-y", help=f"Run without asking even when the run is estimated to take over {LONG_RUN_S:g} s.")
    ] = False,
    end_effector: EndEffectorOption = None,
    max_wall_time: Annotated[
        float | None,
        typer.Option("--max-wall-time", metavar="SECONDS", help="Stop the run after this much computing and write what it computed."),
    ] = None,
) -> None:
    """Simulate a scenario (model, initial state, actuation or controller, duration); write the trajectory and its plots.

    Before the run, its steps and wall time are estimated; a run expected to take over a minute
    asks for confirmation (--yes skips it). Ctrl-C stops the run and writes what was computed.
    """
    import sys

    from .scenarios.scenario import estimate_scenario, load_scenario
    from .scenarios.scenario_outputs import check_animation_target, output_names, simulate_scenario

    with user_errors():
        loaded = load_scenario(scenario, end_effectors=end_effector or None)
        if max_wall_time is not None:
            if not (max_wall_time > 0 and max_wall_time < float("inf")):
                raise ValueError(f"--max-wall-time: expected a positive number of seconds, got {max_wall_time}")
            loaded = dataclasses.replace(loaded, options={**loaded.options, "max_wall_time": max_wall_time})
        if isinstance(out, _EmptyPath):
            output_directory("")
        check_targets(out, output_names(loaded), overwrite=overwrite)
        if animate is not None:  # refused before the run (and before its estimate)
            check_animation_target(animate)
        estimate = estimate_scenario(loaded)
        typer.echo(f"{loaded.source}: {estimate.describe()}", err=True)
        if estimate.seconds > LONG_RUN_S and not yes:
            if not sys.stdin.isatty():
                raise ValueError(f"this run is estimated to take over {LONG_RUN_S:g} s ({estimate.describe()}); pass --yes to run it")
            typer.confirm(f"This run is estimated to take over {LONG_RUN_S:g} s. Run it?", abort=True, err=True)
        with _staged(out, overwrite, "simulate") as target:
            written = simulate_scenario(loaded, target.stage, progress=progress, animation=animate)
        written = target.final(written)
        status = json.loads(written[0].read_text())["status"] if written and written[0].suffix == ".json" else ""
    for path in written:
        typer.echo(str(path))
    if status == "interrupted":
        typer.echo("interrupted (Ctrl-C): the trajectory computed so far is written above", err=True)
        raise typer.Exit(130)


PAPERS = ("1991", "1992")


@app.command("reproduce")
def reproduce_command(
    paper: Annotated[str, typer.Argument(metavar="PAPER", help="Which paper: 1991 (Papadopoulos & Dubowsky) or 1992 (Papadopoulos).")],
    out: Annotated[
        Path,
        typer.Option("--out", parser=_out_path, metavar="DIR", help="Output directory (created): report.json, report.md and the figures."),
    ] = Path("out"),
    overwrite: Overwrite = False,
) -> None:
    """Reproduce a paper's tables, example and figures; write the paper-vs-freefloat report to OUT."""
    with user_errors():
        if paper not in PAPERS:
            raise ValueError(f"PAPER {paper!r}: unknown; choose one of {', '.join(PAPERS)}")
        if paper == "1991":
            from .papers.reproduce import reproduce_1991 as reproduce
        else:
            from .papers.reproduce import reproduce_1992 as reproduce
        from .papers.reproduce import output_names

        if not isinstance(out, _EmptyPath):
            check_targets(out, output_names(paper), overwrite=overwrite)  # before the work
        with _staged(out, overwrite, f"reproduce {paper}") as target:
            written = reproduce(target.stage)
    for path in target.final(written):
        typer.echo(str(path))


CampaignSpecArg = Annotated[Path, typer.Argument(metavar="SPEC", help="Campaign TOML (schema: docs/campaigns.md).")]
CampaignOut = Annotated[
    Path, typer.Option("--out", parser=_out_path, metavar="DIR", help="Output directory: runs/*.parquet, series.zarr, report/.")
]


@app.command("campaign")
def campaign_command(
    spec: CampaignSpecArg,
    out: CampaignOut,
    scheduler: Annotated[
        str | None,
        typer.Option("--scheduler", metavar="ADDRESS", help="An existing Dask scheduler (tcp://host:port). Default: a local cluster."),
    ] = None,
    workers: Annotated[
        int | None, typer.Option("--workers", metavar="N", help="Worker processes of the local cluster (default 1).")
    ] = None,
    memory_limit: Annotated[
        str | None, typer.Option("--memory-limit", metavar="SIZE", help="Memory per local worker, e.g. 2GiB (default: a share of RAM).")
    ] = None,
    resume: Annotated[bool, typer.Option("--resume", help="Run only the runs that DIR does not hold yet.")] = False,
    max_runs: Annotated[int | None, typer.Option("--max-runs", metavar="N", help="Only the first N runs of the plan.")] = None,
    progress: Annotated[
        bool | None,
        typer.Option("--progress/--no-progress", help="Progress on stderr (default: a bar on a terminal; elsewhere a line every 10 s)."),
    ] = None,
    worker_timeout: Annotated[
        float | None,
        typer.Option("--worker-timeout", metavar="SECONDS", help="Seconds a cluster may have no worker before it stops (default 60)."),
    ] = None,
) -> None:
    """Run a campaign: a scenario many times with values varied, on a Dask cluster; results kept as runs finish.

    Ctrl-C stops submitting, waits for the runs in progress and keeps every finished run; --resume goes on.
    The summary tables and plots go to DIR/report/."""
    from .campaigns import load_campaign, run_campaign, summarize_campaign, write_campaign_report

    with user_errors():
        if isinstance(out, _EmptyPath):
            output_directory("")
        loaded = load_campaign(spec)
        done = run_campaign(
            loaded, out, scheduler=scheduler, workers=workers, memory_limit=memory_limit, resume=resume, max_runs=max_runs,
            progress=progress, worker_timeout=worker_timeout,
        )  # fmt: skip
        written = write_campaign_report(summarize_campaign(out, loaded), out) if done.ok + done.failed + done.skipped else []
    typer.echo(done.line())
    for path in written:
        typer.echo(f"wrote {path}", err=True)
    if done.interrupted:
        raise typer.Exit(130)


def main() -> None:
    """Entry point of the ``freefloat`` script and of ``python -m freefloat``.

    SIGTERM (``kill``, a batch system's time limit) is taken as Ctrl-C: a running simulation returns
    what it computed and the command writes it, and no staging folder is left in ``--out``.
    """
    import signal

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    with contextlib.suppress(ValueError):  # not the main thread (an embedding application): leave the signal alone
        signal.signal(signal.SIGTERM, interrupt)
    # progress outside a terminal (a batch job's log): the freefloat.progress logger's lines on stderr
    import logging

    handler = logging.StreamHandler()
    handler.setFormatter(logging.Formatter("freefloat: %(message)s"))
    progress_log = logging.getLogger("freefloat.progress")
    progress_log.addHandler(handler)
    progress_log.setLevel(logging.INFO)
    app(prog_name="freefloat")
