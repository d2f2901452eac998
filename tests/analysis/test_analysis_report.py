"""The command end to end: pictures, HTML report, terminal tables, the reward what-if, track handling and s3://."""

from __future__ import annotations

import base64
import io
import re

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from PIL import Image

from racer.analysis import aggregate, whatif
from racer.analysis.cli import analyze_command
from racer.analysis.loading import load_steps
from racer.analysis.sources import open_source
from racer.analysis.track_sections import load_track
from racer.shared.store import S3Store

TRACK_PICTURES = {"best_laps.png", "reward_heatmap.png", "action_usage.png", "evaluation_laps.png"}


def run(*args: str):
    result = CliRunner().invoke(analyze_command, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return result


def assert_real_picture(data: bytes, name: str) -> None:
    """Decodes as PNG, is reasonably large, and is not one flat colour (a blank or failed plot)."""
    image = Image.open(io.BytesIO(data))
    assert image.format == "PNG", name
    image.load()
    assert image.width >= 400 and image.height >= 300, (name, image.size)
    pixels = np.asarray(image.convert("RGB")).reshape(-1, 3)
    colours = np.unique(pixels[:: max(1, len(pixels) // 200_000)], axis=0)
    assert len(colours) > 50, f"{name}: only {len(colours)} colours"
    background = np.all(pixels == [255, 255, 255], axis=1).mean()
    assert background < 0.97, f"{name}: {background:.1%} white"


@pytest.mark.slow
def test_report_with_track_and_reward_whatif(console_export, reinvent_route, deepracer_data, tmp_path):
    out = tmp_path / "report"
    reward = deepracer_data / "reward_functions/dpr401_prevent_zig_zag.py"
    result = run(console_export, "--track", reinvent_route, "--out", out, "--reward-function", reward)

    pngs = {p.name for p in out.glob("*.png")}
    assert pngs == TRACK_PICTURES | {"training_progress.png", "reward_whatif.png"}
    for png in pngs:
        assert_real_picture((out / png).read_bytes(), png)

    html = (out / "report.html").read_text()
    embedded = re.findall(r"src='data:image/png;base64,([A-Za-z0-9+/=]+)'", html)
    assert len(embedded) == len(pngs)
    for data in embedded:
        assert_real_picture(base64.b64decode(data), "embedded")
    assert "Training iterations" in html and "Evaluation laps" in html and "Reward what-if" in html

    # The terminal shows the key tables with numbers that match the CSVs written next to the report.
    iterations = pd.read_csv(out / "iterations.csv")
    assert list(iterations["iteration"]) == [0, 1, 27]
    assert "Training iterations" in result.output and "Fastest training laps" in result.output
    assert f"{iterations['best_lap_time_s'].min():.3f}" in result.output
    laps = pd.read_csv(out / "evaluation_laps.csv")
    assert len(laps) == 3 and f"{laps['lap_time_s'].min():.3f}" in result.output


def test_without_a_track_gives_tables_and_a_clear_note(drfc_single, tmp_path):
    out = tmp_path / "report"
    result = run(drfc_single, "--out", out)
    assert "no track pictures" in result.output
    assert {p.name for p in out.glob("*.png")} == {"training_progress.png"}
    assert_real_picture((out / "training_progress.png").read_bytes(), "training_progress.png")
    assert "no track pictures" in (out / "report.html").read_text()
    assert (out / "episodes.csv").is_file() and (out / "evaluation_laps.csv").is_file()


def test_track_by_name_from_the_runs_params_yaml(drfc_single, deepracer_data, tmp_path):
    (drfc_single / "training_params.yaml").write_text("WORLD_NAME: reinvent_base\nNUMBER_OF_TRIALS: '3'\n")
    out = tmp_path / "report"
    result = run(drfc_single, "--tracks-dir", deepracer_data / "routes", "--out", out, "--top", 2)
    assert "Track 'reinvent_base' taken from the run's params yaml" in result.output
    assert TRACK_PICTURES <= {p.name for p in out.glob("*.png")}
    # With no tracks folder, the SimApp's reinvent_base comes by name (fetched into the cache on first use).
    result = run(drfc_single, "--out", tmp_path / "r2", "--top", 2)
    assert TRACK_PICTURES <= {p.name for p in (tmp_path / "r2").glob("*.png")}
    # A track racer cannot find anywhere: the run falls back to tables with a note naming it.
    (drfc_single / "training_params.yaml").write_text("WORLD_NAME: my_own_track\nNUMBER_OF_TRIALS: '3'\n")
    result = run(drfc_single, "--out", tmp_path / "r3", "--no-pictures")
    assert "'my_own_track', which is not in the tracks folder" in result.output


def test_unknown_track_is_an_error_naming_it(drfc_single, tmp_path):
    result = CliRunner().invoke(analyze_command, [str(drfc_single), "--track", "no_such_track", "--out", str(tmp_path)])
    assert result.exit_code == 1
    assert "no_such_track" in result.output


def test_reward_whatif_reproduces_the_logged_reward(drfc_single, reinvent_route, deepracer_data):
    """DRfC's sample run was trained with follow_center_line: replaying it on the logged steps gives the logged
    reward on every step; another function gives a different one."""
    steps = load_steps(open_source(str(drfc_single)), progress=False)
    track = load_track(str(reinvent_route))
    logged = steps.loc[steps["phase"] == "training", "reward"]
    same = whatif.replay_reward(
        steps, track, deepracer_data / "reward_functions/drfc1_follow_center_line.py", show_progress=False
    )
    assert len(same) == len(logged) > 3000
    assert np.allclose(same, logged, rtol=0, atol=1e-12)
    other = whatif.replay_reward(
        steps, track, deepracer_data / "reward_functions/dpr401_prevent_zig_zag.py", show_progress=False
    )
    assert not np.allclose(other, logged)
    episodes, by_iteration = whatif.compare(steps, other, aggregate.episodes(steps))
    assert len(episodes) == (steps["phase"] == "training").groupby([steps["worker"], steps["episode"]]).any().sum()
    assert (by_iteration["new_reward_mean"] < by_iteration["reward_mean"]).all()  # zig-zag penalty only lowers


def test_s3_source_on_minio(s3_settings, drfc_multi, console_export, monkeypatch, tmp_path):
    """A DRfC multi-worker prefix and a console export uploaded to a real MinIO, analysed by s3:// URL."""
    store = S3Store(s3_settings)
    for root, prefix in ((drfc_multi, "rl-model"), (console_export, "console/model-a")):
        for path in root.rglob("*.csv"):
            store.put_bytes(f"{prefix}/{path.relative_to(root).as_posix()}", path.read_bytes())
    store.put_bytes("rl-model-other/training-simtrace/0-iteration.csv", b"not even a header\n")  # a sibling prefix
    monkeypatch.setenv("S3_ENDPOINT_URL", s3_settings.endpoint_url)
    monkeypatch.setenv("AWS_ACCESS_KEY_ID", s3_settings.access_key_id)
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", s3_settings.secret_access_key)

    for root, prefix in ((drfc_multi, "rl-model"), (console_export, "console/model-a")):
        out = tmp_path / prefix.replace("/", "_")
        run(f"s3://{s3_settings.bucket}/{prefix}", "--out", out, "--no-pictures")
        local = aggregate.episodes(load_steps(open_source(str(root)), progress=False))
        remote = pd.read_csv(out / "episodes.csv")
        assert len(remote) == len(local)
        assert remote["lap_time_s"].min() == pytest.approx(local["lap_time_s"].min())
        assert sorted(remote["worker"].unique()) == sorted(local["worker"].unique())

    # A model prefix with RACER_STORE pointing at the bucket reads the same files.
    monkeypatch.setenv("RACER_STORE", f"s3://{s3_settings.bucket}")
    run("rl-model", "--out", tmp_path / "by-prefix", "--no-pictures")
    assert pd.read_csv(tmp_path / "by-prefix/episodes.csv").equals(pd.read_csv(tmp_path / "rl-model/episodes.csv"))

    result = CliRunner().invoke(analyze_command, [f"s3://{s3_settings.bucket}/nothing-here", "--out", str(tmp_path)])
    assert result.exit_code == 1 and "no simtrace CSV found" in result.output
    result = CliRunner().invoke(analyze_command, ["rl-model-other", "--out", str(tmp_path)])
    assert result.exit_code == 1
    assert f"s3://{s3_settings.bucket}/rl-model-other/training-simtrace/0-iteration.csv: line 1" in result.output


def test_reward_function_errors_are_clear(drfc_single, reinvent_route, tmp_path):
    broken = tmp_path / "broken_reward.py"
    broken.write_text("def reward_function(params):\n    return params['no_such_key']\n")
    result = CliRunner().invoke(
        analyze_command,
        [
            str(drfc_single),
            "--track",
            str(reinvent_route),
            "--no-pictures",
            "--out",
            str(tmp_path / "o"),
            "--reward-function",
            str(broken),
        ],
    )
    assert result.exit_code == 1
    assert str(broken) in result.output and "line 2" in result.output and "no_such_key" in result.output
    result = CliRunner().invoke(
        analyze_command,
        [str(drfc_single), "--no-pictures", "--out", str(tmp_path / "o"), "--reward-function", str(broken)],
    )
    assert result.exit_code == 1 and "--track" in result.output


def test_workers_on_another_track_are_left_out_of_track_pictures(drfc_multi, deepracer_data, reinvent_route, tmp_path):
    """Multi-config training (training_params_<i>.yaml): worker 1 on another track must not be drawn on worker 0's."""
    (drfc_multi / "training_params.yaml").write_text("WORLD_NAME: reinvent_base\n")
    (drfc_multi / "training_params_1.yaml").write_text("WORLD_NAME: Vegas_track\n")
    out = tmp_path / "o"
    result = run(
        drfc_multi,
        "--tracks-dir",
        deepracer_data / "routes",
        "--out",
        out,
        "--no-pictures",
        "--reward-function",
        deepracer_data / "reward_functions/drfc1_follow_center_line.py",
    )
    assert "worker 1: Vegas_track" in result.output and "left out of the track pictures" in result.output
    whatif_table = pd.read_csv(out / "reward_whatif.csv")
    episodes = pd.read_csv(out / "episodes.csv")
    assert whatif_table["episodes"].sum() == (episodes["worker"] == 0).sum() < len(episodes)
    assert np.allclose(whatif_table["new_reward_mean"], whatif_table["reward_mean"])


@pytest.mark.parametrize("sections", [7])
def test_action_usage_shares_add_up_to_the_logged_action_counts(console_export, reinvent_route, tmp_path, sections):
    """Per section the shares sum to 1, and weighted by each section's step count they give back the action counts
    of the file (counted here with the csv module)."""
    import csv
    from collections import Counter

    from racer.analysis import plots
    from racer.analysis.track_sections import forward_waypoint, reversed_episodes, section_of_waypoint

    steps = load_steps(open_source(str(console_export)), progress=False)
    training = steps[steps["phase"] == "training"]
    track = load_track(str(reinvent_route))
    waypoint = forward_waypoint(training, reversed_episodes(training, track), track)
    path, usage = plots.action_usage(training, waypoint, track, sections, tmp_path / "a.png")
    assert_real_picture(path.read_bytes(), "a.png")
    assert list(usage.index) == list(range(1, sections + 1))
    assert np.allclose(usage.sum(axis=1), 1.0)

    counts: Counter = Counter()
    for csv_path in sorted((console_export / "sim-trace/training/training-simtrace").glob("*.csv")):
        with open(csv_path, newline="") as handle:
            counts.update(int(row["action"]) for row in csv.DictReader(handle) if row["episode_status"] != "prepare")
    section = section_of_waypoint(track, sections)[waypoint[training["episode_status"] != "prepare"].to_numpy()]
    steps_per_section = np.bincount(section, minlength=sections)
    recovered = (usage.to_numpy() * steps_per_section[:, None]).sum(axis=0)
    labels = [int(label.split(":")[0]) for label in usage.columns]
    assert dict(zip(labels, np.round(recovered).astype(int).tolist(), strict=True)) == {
        action: counts.get(action, 0) for action in labels
    }
    assert set(counts) <= set(labels)


def test_iterations_option_limits_pictures_and_whatif_not_tables(
    console_export, reinvent_route, deepracer_data, tmp_path
):
    from racer.analysis.cli import parse_range

    assert parse_range("27") == (27, 27) and parse_range("20-27") == (20, 27) and parse_range("3-") == (3, None)
    out = tmp_path / "o"
    result = run(
        console_export,
        "--track",
        reinvent_route,
        "--out",
        out,
        "--no-pictures",
        "--iterations",
        "1-",
        "--reward-function",
        deepracer_data / "reward_functions/drfc1_follow_center_line.py",
    )
    assert "training iterations 1 to the last" in result.output
    assert list(pd.read_csv(out / "reward_whatif.csv")["iteration"]) == [1, 27]
    assert list(pd.read_csv(out / "iterations.csv")["iteration"]) == [0, 1, 27]
    bad = CliRunner().invoke(analyze_command, [str(console_export), "--iterations", "9-2"])
    assert bad.exit_code == 2 and "ends before it starts" in bad.output


def test_a_track_that_does_not_fit_the_run_is_flagged(drfc_single, reinvent_route, deepracer_data, tmp_path):
    result = run(
        drfc_single, "--track", deepracer_data / "routes/Vegas_track.npy", "--out", tmp_path / "a", "--no-pictures"
    )
    assert "probably the wrong track" in result.output and "17.71 m" in result.output
    result = run(drfc_single, "--track", reinvent_route, "--out", tmp_path / "b", "--no-pictures")
    assert "wrong track" not in result.output


def test_reward_whatif_sim_time_is_the_clock_before_the_steps_physics(drfc_single, reinvent_route, tmp_path):
    """A row's tstamp is stamped after its physics; the reward function saw the clock when the observation arrived,
    which is the previous row's tstamp in the same file."""
    steps = load_steps(open_source(str(drfc_single)), progress=False)
    track = load_track(str(reinvent_route))
    reward_file = tmp_path / "sim_time_reward.py"
    reward_file.write_text("def reward_function(params):\n    return float(params['sim_time'])\n")
    seen = whatif.replay_reward(steps, track, reward_file, show_progress=False)
    previous_tstamp = steps.groupby("file", sort=False)["tstamp"].shift(1).loc[seen.index]
    called = ~steps.loc[seen.index, "episode_status"].isin(whatif.NOT_CALLED_STATUSES)
    assert called.sum() > 3000
    assert np.allclose(seen[called], previous_tstamp[called], rtol=0, atol=1e-9)
    assert (seen[called] < steps.loc[seen.index[called], "tstamp"]).all()
