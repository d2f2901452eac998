"""`racer model explain`: attention maps that show what a policy responds to in a camera frame.

For each frame the policy's greedy action is explained by Grad-CAM on the last conv layer of the policy tower's camera
embedder (the channel weights are the spatial mean of d logit / d activation; the map is ReLU(sum of weighted
channels), placed at the receptive-field centres of the conv cells) or by gradient saliency (|d logit / d pixel|).
Discrete policies explain the action's logit (before the softmax); continuous ones the mean steering output, signed so
that the map shows what pushes the car to the side it steers to (speed with `--all-actions`). Frames are image files,
converted to the camera's input (160x120, RL Coach's grey), or racer's own camera along the track (`--racer-frames`).

MODEL is a store prefix or anything `racer model import` takes (a folder, archive or s3:// prefix; DeepRacer's frozen
graphs beside model_metadata.json), which is imported into a temporary local store first.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np

from racer.model_io.explain_inputs import (
    FRAME_HEIGHT,
    FRAME_WIDTH,
    LoadedModel,
    load_frames,
    open_model,
    racer_frames_of,
)
from racer.options.model import checkpoint_option
from racer.shared.sim.config import DEFAULT_TRACK

PANEL_SCALE = 4
"""Per-frame PNGs are the frame at 4x (640x480) under a title bar."""
SHEET_FRAMES = 24
SHEET_COLUMNS = 6
SHEET_SCALE = 2
HEAT_ALPHA = 0.65


@dataclass(frozen=True)
class Explanation:
    """Greedy actions and their maps for N frames; `maps` (N, 120, 160), finite and >= 0."""

    actions: np.ndarray
    probabilities: np.ndarray
    """The greedy action's probability (discrete), NaN for continuous policies."""
    outputs: np.ndarray
    """(N, A): action probabilities (discrete) or the network's mean action (continuous)."""
    maps: np.ndarray
    all_maps: np.ndarray | None = None
    """(N, A, 120, 160) with --all-actions."""


# -- attribution ----------------------------------------------------------------------------------------------------


def _camera_spec(network):
    cameras = [spec for spec in network.config.inputs if spec.kind == "camera"]
    others = [spec.name for spec in network.config.inputs if spec.kind != "camera"]
    if len(cameras) != 1 or others:
        names = [spec.name for spec in network.config.inputs]
        raise click.ClickException(f"explain takes models with one camera and no lidar; this one reads {names}")
    return cameras[0]


def _head(network, observations):
    """Discrete: the logits; continuous: the Gaussian mean (PPO) or the pre-tanh mean (SAC)."""
    if hasattr(network, "policy_distribution"):
        return network.policy_distribution(observations)[0]
    return network.policy_head(network.policy_tower(observations))


def _cell_grid(network, spec) -> tuple[float, float]:
    """(offset, stride) in pixels of the last conv cells' receptive-field centres."""
    convs, _ = network.config.embedder_layers(spec)
    field, jump = 1, 1
    for conv in convs:
        field += (conv.kernel_px - 1) * jump
        jump *= conv.stride_px
    return (field - 1) / 2, float(jump)


def _to_pixels(cells, offset: float, stride: float):
    """(N, h, w) cell map -> (N, 120, 160), bilinear between receptive-field centres, constant beyond them."""
    import torch

    _, height, width = cells.shape

    def axis(pixels: int, count: int):
        position = ((torch.arange(pixels, dtype=torch.float32) - offset) / stride).clamp(0, count - 1)
        return 2 * position / max(count - 1, 1) - 1

    grid_y, grid_x = torch.meshgrid(axis(FRAME_HEIGHT, height), axis(FRAME_WIDTH, width), indexing="ij")
    grid = torch.stack([grid_x, grid_y], dim=-1).expand(len(cells), -1, -1, -1)
    return torch.nn.functional.grid_sample(cells[:, None], grid, mode="bilinear", align_corners=True)[:, 0]


def attribution(network, grey: np.ndarray, targets: np.ndarray, signs: np.ndarray, method: str) -> np.ndarray:
    """(N, 120, 160) maps of `signs * output[targets]` for each frame (one backward pass for the batch)."""
    import torch

    spec = _camera_spec(network)
    embedder = network.policy_tower.embedders[spec.name]
    captured = {}
    handle = embedder.convs.register_forward_hook(lambda module, args, output: captured.update(a=output))
    try:
        images = torch.from_numpy(np.repeat(grey[..., None], spec.shape[2], axis=-1)).float()
        images.requires_grad_(method == "saliency")
        outputs = _head(network, {spec.name: images})
        chosen = outputs.gather(1, torch.from_numpy(targets).long()[:, None])[:, 0]
        objective = (chosen * torch.from_numpy(signs).float()).sum()
        if method == "saliency":
            (grad,) = torch.autograd.grad(objective, images)
            maps = grad.abs().amax(dim=-1)
        else:
            activations = captured["a"]
            (grad,) = torch.autograd.grad(objective, activations)
            weights = grad.mean(dim=(2, 3), keepdim=True)
            cells = torch.relu((weights * activations).sum(dim=1))
            maps = _to_pixels(cells, *_cell_grid(network, spec)).clamp_min(0)
    finally:
        handle.remove()
    return np.nan_to_num(maps.detach().double().numpy(), nan=0.0, posinf=0.0)


def explain_frames(network, grey: np.ndarray, method: str = "gradcam", all_actions: bool = False) -> Explanation:
    """Greedy actions and their maps for (N, 120, 160) uint8 grey frames."""
    import torch

    spec = _camera_spec(network)
    continuous = network.config.is_continuous
    with torch.no_grad():
        images = torch.from_numpy(np.repeat(grey[..., None], spec.shape[2], axis=-1))
        if continuous:
            outputs = network.policy_output({spec.name: images}).double().numpy()
        else:
            outputs = network.distribution({spec.name: images}).probs.double().numpy()
    count = len(grey)
    if continuous:
        actions = np.zeros(count, dtype=np.int64)  # the steering output
        probabilities = np.full(count, np.nan)
        signs = np.where(outputs[:, 0] < 0, -1.0, 1.0)
    else:
        actions = outputs.argmax(axis=1)
        probabilities = outputs[np.arange(count), actions]
        signs = np.ones(count)
    maps = attribution(network, grey, actions, signs, method)
    all_maps = None
    if all_actions:
        per_action = []
        for index in range(outputs.shape[1]):
            sign = signs if continuous and index == 0 else np.ones(count)
            per_action.append(attribution(network, grey, np.full(count, index), sign, method))
        all_maps = np.stack(per_action, axis=1)
    return Explanation(actions, probabilities, outputs, maps, all_maps)


def attention_shares(heat: np.ndarray) -> dict[str, float] | None:
    """Where a map's mass lies: upper third, upper / lower half, left / centre / right third; None when empty."""
    total = float(heat.sum())
    if not np.isfinite(total) or total <= 0:
        return None
    third = FRAME_WIDTH // 3
    return {
        "upper_third": float(heat[: FRAME_HEIGHT // 3].sum()) / total,  # walls and what is above them
        "upper_half": float(heat[: FRAME_HEIGHT // 2].sum()) / total,
        "lower_half": float(heat[FRAME_HEIGHT // 2 :].sum()) / total,
        "left_third": float(heat[:, :third].sum()) / total,
        "centre_third": float(heat[:, third : FRAME_WIDTH - third].sum()) / total,
        "right_third": float(heat[:, FRAME_WIDTH - third :].sum()) / total,
    }


def action_text(metadata, outputs: np.ndarray, action: int, index: int | None = None) -> str:
    """`action 6: 0°, 2.0 m/s, p=0.87`; continuous: the scaled mean (and which output a panel explains)."""
    if metadata.is_continuous:
        steering, speed = metadata.scale_continuous_action(outputs)  # PPO's mean, SAC's tanh(mean)
        which = "" if index is None else (" (steering)" if index == 0 else " (speed)")
        return f"mean {steering:+.1f}°, {speed:.2f} m/s{which}"
    chosen = metadata.discrete_actions[action]
    return f"action {action}: {chosen.steering_angle_deg:+g}°, {chosen.speed_mps:g} m/s, p={outputs[action]:.2f}"


# -- drawing --------------------------------------------------------------------------------------------------------


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1
        return ImageFont.load_default()


def title_height(scale: int = PANEL_SCALE) -> int:
    """Pixels of the two-line title above a panel (34 at the per-frame scale, 28 on the contact sheet)."""
    return 34 if scale >= PANEL_SCALE else 28


def panel(grey: np.ndarray, heat: np.ndarray, lines: list[str], scale: int = PANEL_SCALE):
    """The frame at `scale`x with the map as a colour heat map (opacity grows with attention), titled."""
    import matplotlib
    from PIL import Image, ImageDraw

    peak = float(np.percentile(heat, 99.5)) or float(heat.max())  # saliency is speckled: no few pixels set the scale
    strength = np.clip(heat / peak, 0, 1) if peak > 0 else np.zeros_like(heat)
    colours = matplotlib.colormaps["jet"](strength)[..., :3]
    alpha = HEAT_ALPHA * strength[..., None]
    blended = (grey[..., None] / 255.0) * (1 - alpha) + colours * alpha
    frame = Image.fromarray(np.round(blended * 255).astype(np.uint8))
    frame = frame.resize((FRAME_WIDTH * scale, FRAME_HEIGHT * scale), Image.Resampling.BILINEAR)
    font_px = 13 if scale >= PANEL_SCALE else 10
    title_px = title_height(scale)
    image = Image.new("RGB", (frame.width, frame.height + title_px), "white")
    image.paste(frame, (0, title_px))
    draw = ImageDraw.Draw(image)
    for row, line in enumerate(lines[:2]):
        draw.text((4, 2 + row * (font_px + 3)), line, fill="black", font=_font(font_px))
    return image


def grid(images: list, columns: int):
    from PIL import Image

    width, height = images[0].size
    rows = -(-len(images) // columns)
    sheet = Image.new("RGB", (width * min(columns, len(images)), height * rows), "white")
    for k, image in enumerate(images):
        sheet.paste(image, ((k % columns) * width, (k // columns) * height))
    return sheet


# -- the report -----------------------------------------------------------------------------------------------------


def run_explain(
    model: LoadedModel, names: list[str], grey: np.ndarray, out: Path, method: str, all_actions: bool
) -> dict:
    """Writes one PNG per frame (`<k>-<name>.png`, with --all-actions also `<k>-<name>-actions.png`), the contact sheet
    `explain.png` and `explain.json` (per frame); returns the summary."""
    metadata = model.metadata
    result = explain_frames(model.network, grey, method, all_actions)
    out.mkdir(parents=True, exist_ok=True)
    records, tiles = [], []
    sheet_frames = set(np.linspace(0, len(grey) - 1, min(SHEET_FRAMES, len(grey))).round().astype(int).tolist())
    for k, (name, frame, heat) in enumerate(zip(names, grey, result.maps, strict=True)):
        action = int(result.actions[k])
        text = action_text(metadata, result.outputs[k], action)
        lines = [f"{name} · {model.checkpoint} · {method}", text]
        panel(frame, heat, lines).save(out / f"{k:03d}-{name}.png")
        if k in sheet_frames:
            tiles.append(panel(frame, heat, lines, scale=SHEET_SCALE))
        if result.all_maps is not None:
            panels = [
                panel(frame, result.all_maps[k, index], [name, action_text(metadata, result.outputs[k], index, index)])
                for index in range(result.all_maps.shape[1])
            ]
            grid(panels, 4).save(out / f"{k:03d}-{name}-actions.png")
        records.append(
            {"frame": name, "action": action, "label": text, "attention": attention_shares(heat), "mass": heat.sum()}
        )
    grid(tiles, SHEET_COLUMNS).save(out / "explain.png")
    (out / "explain.json").write_text(json.dumps(records, indent=1, default=float) + "\n")
    return summarise(model, result, records, method, out)


def summarise(model: LoadedModel, result: Explanation, records: list[dict], method: str, out: Path) -> dict:
    metadata = model.metadata
    count = len(records)
    if metadata.is_continuous:
        steering = [metadata.scale_continuous_action(row)[0] for row in result.outputs]
        sides = np.sign([0.0 if abs(value) < 1.0 else value for value in steering])
        action_shares = {}
    else:
        labels = [record["label"].split(", p=")[0] for record in records]
        order = sorted(set(labels), key=lambda label: int(label.split(":")[0].split()[-1]))
        action_shares = {label: round(labels.count(label) / count, 3) for label in order}
        sides = np.sign([metadata.discrete_actions[int(a)].steering_angle_deg for a in result.actions])
    shares = [record["attention"] for record in records if record["attention"] is not None]
    attention = {key: round(float(np.mean([s[key] for s in shares])), 3) for key in shares[0]} if shares else {}
    return {
        "model": model.label,
        "checkpoint": model.checkpoint,
        "method": method,
        "frames": count,
        "greedy_action_shares": action_shares,
        "steering_shares": {
            side: round(float(np.mean(sides == value)), 3)
            for side, value in (("left", 1), ("straight", 0), ("right", -1))
        },
        "mean_greedy_probability": None if metadata.is_continuous else round(float(result.probabilities.mean()), 3),
        "attention": attention,
        "empty_maps": count - len(shares),
        "out": str(out),
    }


@click.command("explain", short_help="Attention maps (Grad-CAM or saliency) of a policy over camera frames.")
@click.argument("model")
@click.argument("frames", nargs=-1, type=click.Path(exists=True, path_type=Path))
@click.option("--out", type=click.Path(file_okay=False, path_type=Path), default=Path("explain"), show_default=True)
@click.option("--method", type=click.Choice(["gradcam", "saliency"]), default="gradcam", show_default=True)
@checkpoint_option
@click.option(
    "--store", "store_location", default=None, help="This system's store (for a store prefix). Default: RACER_STORE."
)
@click.option("--all-actions", is_flag=True, help="Also a sheet per frame with every action's map.")
@click.option(
    "--racer-frames", type=click.IntRange(min=0), default=0, help="Add N frames of racer's camera around the lap."
)
@click.option("--world", default="base", show_default=True, help="The world of --racer-frames.")
@click.option(
    "--track",
    default=DEFAULT_TRACK,
    show_default=True,
    help="The track of --racer-frames: a name on the route search path or a route .npy file.",
)
def explain_command(
    model: str,
    frames: tuple[Path, ...],
    out: Path,
    method: str,
    checkpoint: str,
    store_location: str | None,
    all_actions: bool,
    racer_frames: int,
    world: str,
    track: str,
) -> None:
    """Draw what MODEL's policy looks at in FRAMES (PNG/JPEG files or folders of them) for its greedy action.

    MODEL is a store prefix, a racer model folder or anything `racer model import` takes (DeepRacer's frozen graphs
    too; imported into a temporary store). Writes a PNG per frame, the contact sheet explain.png (up to 24 frames)
    and explain.json into --out, and prints a one-line JSON summary (action shares, where the attention lies).
    """
    if not frames and not racer_frames:
        raise click.UsageError("give FRAMES (image files or folders) or --racer-frames N")
    names, grey = load_frames(frames) if frames else ([], np.zeros((0, FRAME_HEIGHT, FRAME_WIDTH), np.uint8))
    if racer_frames:
        from racer.shared.sim.scene.worlds import WORLD_NAMES

        if world not in WORLD_NAMES:
            raise click.BadParameter(f"{world!r}: choose from {', '.join(WORLD_NAMES)}", param_hint="--world")
        rendered_names, rendered = racer_frames_of(racer_frames, world, track)
        names, grey = names + rendered_names, np.concatenate([grey, rendered])
    with open_model(model, store_location, checkpoint) as loaded:
        click.echo(json.dumps(run_explain(loaded, names, grey, out, method, all_actions)))
