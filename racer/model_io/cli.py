"""`racer model validate | import | export | explain`.

Exit status: 0 when the model is fine / the copy succeeded, 1 when problems were printed (each with the
DeepRacer console's code and a fix), 2 for usage errors.
"""

from __future__ import annotations

import sys
from pathlib import Path

import click

from racer.model_io.deepracer_export import EXPORT_LAYOUTS
from racer.model_io.deepracer_import import (
    convert_tf_checkpoints,
    find_model_root,
    frozen_graph_keys,
    graph_checkpoint_number,
    import_frozen_graphs,
    tensorflow_only_checkpoints,
)
from racer.model_io.destinations import ArchiveDestination, Destination, FolderDestination, StoreDestination
from racer.model_io.explain import explain_command
from racer.model_io.import_export import MODEL_NAME, ImportExportResult, ModelExistsError, export_model, import_model
from racer.model_io.problems import ValidationProblem, ValidationReport
from racer.model_io.sources import split_s3_location
from racer.model_io.store_location import open_store_option
from racer.model_io.tensorflow.errors import CustomNetworkExportError, UnsupportedGraphError
from racer.model_io.tensorflow.runner import (
    INSTALL_HINT,
    TensorFlowMissingError,
    TensorFlowToolError,
    tensorflow_available,
)
from racer.model_io.validate import validate_location, validate_model
from racer.shared.config import S3Settings, store_settings_at
from racer.shared.model_layout import COACH_CHECKPOINT, DEEPRACER_CHECKPOINTS
from racer.shared.store import S3Store

STORE_HELP = (
    "This system's store: s3://bucket (endpoint and keys from S3_ENDPOINT_URL, AWS_*) or a folder. "
    "Default: RACER_STORE."
)


def _print_problems(problems: tuple[ValidationProblem, ...]) -> None:
    for problem in problems:
        click.echo(problem.render())


def _print_report(report: ValidationReport) -> None:
    _print_problems(report.problems)
    if report.plan is not None:
        selection = report.plan.selection
        if selection.source == COACH_CHECKPOINT:
            chosen = f"{COACH_CHECKPOINT} names {selection.pointer}"
        else:
            chosen = f"{DEEPRACER_CHECKPOINTS}: best {selection.best}, last {selection.pointer}"
        click.echo(
            f"OK  {report.source}: import-ready. Checkpoints {', '.join(selection.checkpoints)} ({chosen}); "
            f"{report.plan.total_bytes} bytes to copy."
        )
    for note in report.notes:
        click.echo(f"note: {note}")
    if report.problems:
        count = len(report.problems)
        click.echo(f"{count} problem{'s' if count != 1 else ''}: {report.source} cannot be imported as it is.")


@click.group("model")
def model_group() -> None:
    """Validate, import and export models in DeepRacer's layout, with the console's import error codes."""


@model_group.command(
    "validate", short_help="Check a model folder, .tar.gz or s3://bucket/prefix like the console importer."
)
@click.argument("location")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def validate_command(location: str, as_json: bool) -> None:
    """Check LOCATION (a folder, a .tar.gz, or s3://bucket/prefix) the way the DeepRacer importer did.

    Prints every problem with its console code (e.g. COACH_CHECKPOINT_DOES_NOT_EXIST) and a fix.
    Size limits: 1 GiB for the model (archive, model.tar.gz, files an import copies) and 10 MiB per JSON/YAML
    file (DeepRacer-on-AWS's published limits); 512 MiB per checkpoint file (racer's choice).
    """
    report, _ = validate_location(location)
    if as_json:
        click.echo(report.to_json())
    else:
        _print_report(report)
    sys.exit(0 if report.ok else 1)


@model_group.command("import", short_help="Bring a model in (racer's, DeepRacer's TensorFlow files, DRoA's downloads).")
@click.argument("source")
@click.argument("model_name")
@click.option("--store", "store_location", default=None, help=STORE_HELP)
@click.option("--overwrite", is_flag=True, help="Replace a model of the same name.")
def import_command(source: str, model_name: str, store_location: str | None, overwrite: bool) -> None:
    """Validate SOURCE and copy it into the store as MODEL_NAME (training can clone it, evaluation can run it).

    SOURCE: a model folder, .tar.gz, ZIP or s3://bucket/prefix; DeepRacer on AWS's downloads (the "virtual model"
    package, ZIP or tar.gz; the physical-car tarball; the training-logs tarball when it holds the model).
    Copies best and last checkpoints when model/deepracer_checkpoints.json exists, otherwise the checkpoint
    named by model/.coach_checkpoint and the one before it (the console's logic). TensorFlow checkpoints are then
    converted to racer checkpoints; a frozen graph (agent/model.pb) becomes checkpoint 0 with a fresh value network.
    """
    if not MODEL_NAME.match(model_name):
        raise click.BadParameter(
            f"{model_name!r}: use 1-64 letters, digits and hyphens, starting with a letter or "
            "digit (the console's rule)",
            param_hint="MODEL_NAME",
        )
    report, opened = validate_location(source)
    if opened is not None and not report.ok:
        graph_keys = frozen_graph_keys(opened.list_files())
        if graph_keys:
            _import_graphs(opened, graph_keys, source, model_name, store_location, overwrite)
            return
        nested = find_model_root(opened)
        if nested is not None:
            nested_report = validate_model(nested)
            if nested_report.ok:
                click.echo(f"note: the model is in {nested.describe()}")
                report, opened = nested_report, nested
    if opened is None or not report.ok:
        _print_report(report)
        if opened is not None and not any(key.endswith((".pb", ".index")) for key in opened.list_files()):
            click.echo(
                "note: no model weights here (no checkpoint, no model.pb); a DRoA training-logs download "
                'holds logs and metrics only: download the model itself ("virtual model" or physical car)'
            )
        sys.exit(1)
    store = open_store_option(store_location)
    try:
        result = import_model(opened, store, model_name, overwrite=overwrite)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="MODEL_NAME") from None
    except ModelExistsError as error:
        raise click.ClickException(str(error)) from None
    _finish(result, f"imported {source} as {result.destination}")
    if tensorflow_only_checkpoints(result.written):
        if not tensorflow_available():
            click.echo(
                f"note: the TensorFlow checkpoints were copied but racer cannot run them until they are "
                f"converted: {INSTALL_HINT}; then import again with --overwrite"
            )
            return
        click.echo("converting the TensorFlow checkpoints to racer checkpoints (a TensorFlow process) ...")
        try:
            outcome = convert_tf_checkpoints(store, model_name)
        except (UnsupportedGraphError, TensorFlowToolError) as error:
            reason = str(error).strip().splitlines()[-1]
            click.echo(
                f"warning: {model_name} holds the files as they are, but racer cannot evaluate or train it: "
                f"its TensorFlow checkpoints cannot become racer checkpoints: {reason}"
            )
            return
        for note in outcome.notes:
            click.echo(f"note: {note}")
        click.echo(f"converted {', '.join(outcome.written)} to racer checkpoints")
    click.echo(
        f"model prefix {model_name!r}: clone it with `racer trainer --pretrained-prefix {model_name}`, "
        "or give it as the model prefix to evaluate"
    )


def _import_graphs(
    opened, graph_keys: tuple[str, ...], source: str, model_name: str, store_location: str | None, overwrite: bool
) -> None:
    """A car bundle / frozen graphs: a checkpoint per graph from its policy, a fresh value network."""
    if not tensorflow_available():
        raise click.ClickException(
            f"{source} holds TensorFlow frozen graphs ({', '.join(graph_keys)}); reading them needs TensorFlow: "
            f"{INSTALL_HINT}"
        )
    store = open_store_option(store_location)
    existing = store.list_keys(model_name + "/")
    if existing and not overwrite:
        raise click.ClickException(
            f"{model_name} already holds a model ({len(existing)} files); choose another name or pass --overwrite"
        )
    for key in existing:
        store.delete(key)
    click.echo(f"reading the frozen graphs {', '.join(graph_keys)} (a TensorFlow process each) ...")
    try:
        outcome = import_frozen_graphs(opened, graph_keys, store, model_name)
    except (UnsupportedGraphError, TensorFlowToolError, ValueError) as error:
        raise click.ClickException(f"{source} cannot become a racer model: {error}") from None
    for note in outcome.notes:
        click.echo(f"note: {note}")
    for graph_key, name in zip(sorted(graph_keys, key=graph_checkpoint_number), outcome.written, strict=True):
        click.echo(f"imported the policy of {source}:{graph_key} as {model_name}/model/{name}")
    click.echo(
        f"model prefix {model_name!r}: clone it with `racer trainer --pretrained-prefix {model_name}`, "
        "or give it as the model prefix to evaluate"
    )


@model_group.command(
    "export", short_help="Write a stored model in the import-ready layout plus the car's model.tar.gz."
)
@click.argument("model")
@click.argument("dest")
@click.option("--store", "store_location", default=None, help=STORE_HELP)
@click.option("--overwrite", is_flag=True, help="Write into DEST even if it already holds files.")
@click.option(
    "--for",
    "target",
    type=click.Choice(EXPORT_LAYOUTS),
    default="racer",
    show_default=True,
    help="racer: racer's layout plus DeepRacer's TensorFlow files; droa: the folder DeepRacer on AWS imports.",
)
def export_command(model: str, dest: str, store_location: str | None, overwrite: bool, target: str) -> None:
    """Write MODEL (its prefix in the store) to DEST (a folder, s3://bucket/prefix or a .tar.gz), ready to import.

    DEST gets ip/, model/ (racer's checkpoints and, with the TensorFlow extra, DeepRacer's TensorFlow checkpoints
    and model_<N>.pb), reward_function.py, training_params.yaml, model_metadata.json, metrics/ and the car bundle
    model.tar.gz (model_metadata.json + agent/model.pb, the frozen graph every DeepRacer car loads). With
    --for droa, DEST is the folder DeepRacer on AWS's model import takes (TensorFlow files only). The result is
    validated.
    """
    tensorflow = tensorflow_available()
    if not tensorflow:
        message = (
            f"DeepRacer's TensorFlow files (model.pb for the car, checkpoints for DRoA) need TensorFlow: {INSTALL_HINT}"
        )
        if target == "droa":
            raise click.ClickException(message)
        click.echo(
            f"note: {message}; exporting racer's files only (the car bundle holds agent/model.onnx, which no "
            "DeepRacer software loads)"
        )
    store = open_store_option(store_location)
    destination = _destination(dest, overwrite)
    if tensorflow:
        click.echo("writing DeepRacer's TensorFlow files (a TensorFlow process; this takes a minute) ...")
    try:
        result = export_model(store, model, destination, tensorflow=tensorflow, layout=target)
    except (TensorFlowToolError, TensorFlowMissingError, CustomNetworkExportError) as error:
        raise click.ClickException(str(error)) from None
    _finish(
        result,
        f"exported {model} to {result.destination}"
        + (
            f" (car bundle model.tar.gz: model_metadata.json + {result.car_bundle_model})"
            if result.car_bundle_model
            else " (no inference model for the best checkpoint: no model.tar.gz)"
        ),
    )


def _destination(dest: str, overwrite: bool) -> Destination:
    if dest.startswith("s3://"):
        bucket, prefix = split_s3_location(dest)
        settings = store_settings_at(f"s3://{bucket}")
        assert isinstance(settings, S3Settings)
        store = S3Store(settings)
        if not overwrite and store.list_keys(prefix + "/" if prefix else ""):
            raise click.ClickException(f"{dest} already holds files; choose an empty prefix or pass --overwrite")
        return StoreDestination(store, prefix)
    path = Path(dest).expanduser()
    if dest.endswith((".tar.gz", ".tgz")):
        if path.exists() and not overwrite:
            raise click.ClickException(f"{path} exists; choose another name or pass --overwrite")
        return ArchiveDestination(path)
    if path.exists() and (not path.is_dir() or (any(path.iterdir()) and not overwrite)):
        raise click.ClickException(f"{path} exists and is not an empty folder; choose another or pass --overwrite")
    return FolderDestination(path)


def _finish(result: ImportExportResult, success: str) -> None:
    if not result.report.ok:
        _print_report(result.report)
        sys.exit(1)
    if result.problems:
        _print_problems(result.problems)
        click.echo(f"nothing usable was written to {result.destination}")
        sys.exit(1)
    for note in result.report.notes:
        click.echo(f"note: {note}")
    if result.check is not None and not result.check.ok:
        click.echo(f"the written copy does not validate ({result.destination}):")
        _print_problems(result.check.problems)
        sys.exit(1)
    click.echo(f"{success}: {len(result.written)} files")


model_group.add_command(explain_command)
