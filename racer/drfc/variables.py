"""Every DR_* variable of DeepRacer-for-Cloud's templates, and what racer does with it.

The variables are those of deepracer-for-cloud 2eb1a1f1 `defaults/template-run.env`, `template-system.env` and
`template-worker.env` (commented-out ones included), and the ones its `scripts/training/prepare-config.py` and
`scripts/evaluation/prepare-config.py` read besides. For each, `train` and `evaluate` say how `racer train --drfc` and
`racer evaluate --drfc` treat it, and `racer` says what racer does with it or instead, in the words
docs/coming-from-drfc.md shows (tests/drfc/test_docs_page.py holds the page to this table).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["VARIABLES", "DrfcVariable", "Use", "variable"]


class Use(enum.Enum):
    HONOURED = "honoured"
    """racer does what DRfC does with it."""
    NO_EFFECT = "no effect"
    """It changes nothing that is trained or evaluated (a name, a file name): read, never reported."""
    NOT_HONOURED = "not honoured"
    """DRfC does something with it that racer does not: reported once when set to anything but `inert`."""
    NOT_READ = "not read"
    """DRfC's command (training or evaluation) does not read it either."""


@dataclass(frozen=True)
class DrfcVariable:
    name: str
    racer: str
    """What racer does with it, or instead (docs/coming-from-drfc.md shows this text)."""
    train: Use
    evaluate: Use
    inert: tuple[str, ...] = ()
    """Values (any case) that ask for nothing racer lacks, so a NOT_HONOURED variable set to one is not reported;
    `{DR_LOCAL_S3_MODEL_PREFIX}` stands for that variable's value."""

    def use(self, command: str) -> Use:
        return self.train if command == "train" else self.evaluate

    def is_inert(self, value: str, values: Mapping[str, str]) -> bool:
        filled = {name: values.get(name, "") for name in ("DR_LOCAL_S3_MODEL_PREFIX",)}
        return value.strip().lower() in {v.format_map(filled).lower() for v in self.inert}


H, N, X, R = Use.HONOURED, Use.NO_EFFECT, Use.NOT_HONOURED, Use.NOT_READ
OFF = ("False", "")

STORE = (
    "racer keeps models in its own store, RACER_STORE: a folder (default ./racer-data) or s3://bucket; "
    "`racer train --minio` starts a local MinIO for the run"
)
CONTAINERS = "no containers: racer runs the trainer and the workers as local processes of its Python package"
VIDEO = (
    "no Kinesis or camera streams: `racer train` shows every worker's car camera on its live page (--viewer-port), "
    "`racer evaluate` writes MP4s (in-car, top and follow views)"
)
DISPLAY = "no Gazebo window or X server: racer draws offscreen (EGL or OSMesa); watch on the live page"
GPU = (
    "no GPU pinning: the rollout workers act on the CPU; the trainer's `--device` (auto, cpu, cuda) picks where it "
    "learns"
)
LOGS = "racer writes each process's log to `<store>/.runs/<model>/` and sends nothing to CloudWatch"
MOUNTS = (
    "racer runs no SimApp code, so there is nothing to mount (RACER_SIMAPP_DIR in workers.json borrows a SimApp "
    "bundle's meshes for the camera only)"
)
TELEGRAF = "no Telegraf: the live page and the model's metrics/ in the store show the run"
RTF = "no real-time factor: racer steps the simulation as fast as the CPU allows"
NAMES = "a name for the console, DRfC's video overlay and leaderboards; racer names a model by its prefix"
SHELL = "DeepRacer's own car (body shell deepracer) is the only one racer simulates; `--car-profile` picks its dynamics"
UPLOAD = "used by dr-upload-model; racer's counterpart is `racer model export MODEL s3://bucket/prefix`"
DROA = (
    "used by the droa-* commands; racer talks to no DeepRacer on AWS: `racer model import` takes its downloads and "
    "`racer model export --for droa` writes what it imports"
)
ACTIVATE = "set by activate.sh from DR_CLOUD; racer's store is RACER_STORE"
CUSTOM_FILE_KEY = (
    "which file of the experiment's custom_files/ is the {file}: its key below DR_LOCAL_S3_CUSTOM_FILES_PREFIX, where "
    "dr-upload-custom-files puts custom_files/"
)
OA = "{key} for OBJECT_AVOIDANCE, per worker in training and in the evaluation"
H2B = "{key} for HEAD_TO_BOT, per worker in training and in the evaluation"

VARIABLES: tuple[DrfcVariable, ...] = (
    # run.env
    DrfcVariable("DR_RUN_ID", "each `racer train` has its own Redis and processes; runs are told apart by model "
                 "prefix, so there is no run id", X, X, ("0", "")),
    DrfcVariable("DR_WORLD_NAME", "the track (WORLD_NAME) of each worker and of the evaluation: a SimApp route name, "
                 "its `_cw`/`_ccw` suffix included, fetched on first use (--track)", H, H),
    DrfcVariable("DR_RACE_TYPE", "RACE_TYPE of each worker and of the evaluation: TIME_TRIAL, OBJECT_AVOIDANCE or "
                 "HEAD_TO_BOT; HEAD_TO_MODEL evaluates against DR_EVAL_OPP_S3_MODEL_PREFIX (--opponent)", H, H),
    DrfcVariable("DR_CAR_NAME", NAMES, N, N),
    DrfcVariable("DR_CAR_BODY_SHELL_TYPE", SHELL, X, X, ("deepracer",)),
    DrfcVariable("DR_CAR_COLOR", "the car's colour in DRfC's videos; its own camera does not see it, so it changes "
                 "nothing racer trains or evaluates", N, N),
    DrfcVariable("DR_DISPLAY_NAME", NAMES, N, N),
    DrfcVariable("DR_RACER_NAME", NAMES, N, N),
    DrfcVariable("DR_ENABLE_DOMAIN_RANDOMIZATION", "ENABLE_DOMAIN_RANDOMIZATION of each worker in training (random "
                 "light colours every episode); `racer evaluate` draws the world as it is", H, X, OFF),
    DrfcVariable("DR_EVAL_NUMBER_OF_TRIALS", "--trials (NUMBER_OF_TRIALS)", R, H),
    DrfcVariable("DR_EVAL_IS_CONTINUOUS", "--continuous / --no-continuous (IS_CONTINUOUS)", R, H),
    DrfcVariable("DR_EVAL_MAX_RESETS", "--resets (NUMBER_OF_RESETS): 0, or 2 and more, as in the SimApp", R, H),
    DrfcVariable("DR_EVAL_OFF_TRACK_PENALTY", "--off-track-penalty (OFF_TRACK_PENALTY), seconds", R, H),
    DrfcVariable("DR_EVAL_COLLISION_PENALTY", "no effect in DRfC or racer: DRfC's evaluation prepare-config.py reads "
                 "DR_COLLISION_PENALTY instead (racer says so when the two differ)", R, N),
    DrfcVariable("DR_EVAL_SAVE_MP4", "--video / --no-video: True writes racer's MP4s (in-car, top and follow views)",
                 R, H),
    DrfcVariable("DR_EVAL_CHECKPOINT", "--checkpoint: last or best (DRfC's default is last, racer evaluate's own is "
                 "best)", R, H),
    DrfcVariable("DR_EVAL_OPP_S3_MODEL_PREFIX", "--opponent when DR_RACE_TYPE is HEAD_TO_MODEL: the other model, a "
                 "prefix in racer's store", R, H),
    DrfcVariable("DR_EVAL_OPP_CAR_BODY_SHELL_TYPE", SHELL, R, X, ("deepracer",)),
    DrfcVariable("DR_EVAL_OPP_CAR_NAME", NAMES, R, N),
    DrfcVariable("DR_EVAL_OPP_DISPLAY_NAME", NAMES, R, N),
    DrfcVariable("DR_EVAL_OPP_RACER_NAME", NAMES, R, N),
    DrfcVariable("DR_EVAL_DEBUG_REWARD", "racer evaluate scores with DeepRacer's evaluation reward and does not run "
                 "your reward function; `racer reward test` runs it over a track", R, X, OFF),
    DrfcVariable("DR_EVAL_RESET_BEHIND_DIST", "RESET_BEHIND_DIST (--race-param): how far behind an obstacle a reset "
                 "puts the car", R, H),
    DrfcVariable("DR_EVAL_REVERSE_DIRECTION", "--reverse (REVERSE_DIR)", R, H),
    DrfcVariable("DR_EVAL_RTF", RTF, R, X, ("",)),
    DrfcVariable("DR_TRAIN_CHANGE_START_POSITION", "CHANGE_START_POSITION of each worker: the round-robin start", H, R),
    DrfcVariable("DR_TRAIN_REVERSE_DIRECTION", "REVERSE_DIR of each worker", H, R),
    DrfcVariable("DR_TRAIN_ALTERNATE_DRIVING_DIRECTION", "ALTERNATE_DRIVING_DIRECTION of each worker", H, R),
    DrfcVariable("DR_TRAIN_START_POSITION_OFFSET", "START_POSITION_OFFSET of each worker: where the first episode "
                 "starts, as a fraction of the lap", H, R),
    DrfcVariable("DR_TRAIN_ROUND_ROBIN_ADVANCE_DIST", "ROUND_ROBIN_ADVANCE_DIST of each worker: how far each episode "
                 "starts beyond the last, as a fraction of the lap", H, R),
    DrfcVariable("DR_TRAIN_MULTI_CONFIG", "exactly True (DRfC compares the text) with more than one worker: "
                 "worker-N.env sets workers 2 and up, carried into racer's per-worker settings (workers.json)", H, R),
    DrfcVariable("DR_TRAIN_MIN_EVAL_TRIALS", "MIN_EVAL_TRIALS: worker 0's evaluation episodes per checkpoint", H, R),
    DrfcVariable("DR_TRAIN_BEST_MODEL_METRIC", "BEST_MODEL_METRIC: progress or reward (racer also takes laptime)", H,
                 R),
    DrfcVariable("DR_TRAIN_RTF", RTF, X, R, ("",)),
    DrfcVariable("DR_TRAIN_MAX_STEPS_PER_ITERATION", "not read from the env files: racer applies DeepRacer's cap "
                 "itself; for another, run racer train with MAX_MEMORY_STEPS=N in its environment (racer trainer "
                 "--max-memory-steps)", X, R, ("",)),
    DrfcVariable("DR_LOCAL_S3_MODEL_PREFIX", "--model-prefix: the model's name in racer's store", H, H),
    DrfcVariable("DR_LOCAL_S3_PRETRAINED", "True (or yes, t, 1, as the SimApp reads it): the run clones "
                 "DR_LOCAL_S3_PRETRAINED_PREFIX", H, R),
    DrfcVariable("DR_LOCAL_S3_PRETRAINED_PREFIX", "--pretrained-prefix when DR_LOCAL_S3_PRETRAINED is true: a model "
                 "in racer's store (`racer model import` brings one in)", H, R),
    DrfcVariable("DR_LOCAL_S3_PRETRAINED_CHECKPOINT", "--pretrained-checkpoint: best when it says best (any case), "
                 "else last, as the SimApp", H, R),
    DrfcVariable("DR_LOCAL_S3_CUSTOM_FILES_PREFIX", "where dr-upload-custom-files puts custom_files/: the three keys "
                 "below name files of the experiment's custom_files/ relative to it", H, R),
    DrfcVariable("DR_LOCAL_S3_TRAINING_PARAMS_FILE", "racer writes training_params.yaml (and one file per further "
                 "worker) under the model prefix, whatever this says", X, R, ("training_params.yaml",)),
    DrfcVariable("DR_LOCAL_S3_EVAL_PARAMS_FILE", "the yaml DRfC hands its evaluation container; racer evaluate "
                 "needs none", R, N),
    DrfcVariable("DR_LOCAL_S3_MODEL_METADATA_KEY", CUSTOM_FILE_KEY.format(file="model_metadata.json"), H, R),
    DrfcVariable("DR_LOCAL_S3_HYPERPARAMETERS_KEY", CUSTOM_FILE_KEY.format(file="hyperparameters.json"), H, R),
    DrfcVariable("DR_LOCAL_S3_REWARD_KEY", CUSTOM_FILE_KEY.format(file="reward_function.py"), H, R),
    DrfcVariable("DR_LOCAL_S3_METRICS_PREFIX", "racer writes metrics under the model prefix (metrics/), as DRfC's "
                 "default", X, X, ("{DR_LOCAL_S3_MODEL_PREFIX}/metrics",)),
    DrfcVariable("DR_UPLOAD_S3_PREFIX", UPLOAD, R, R),
    DrfcVariable("DR_OA_NUMBER_OF_OBSTACLES", OA.format(key="NUMBER_OF_OBSTACLES"), H, H),
    DrfcVariable("DR_OA_MIN_DISTANCE_BETWEEN_OBSTACLES", OA.format(key="MIN_DISTANCE_BETWEEN_OBSTACLES"), H, H),
    DrfcVariable("DR_OA_RANDOMIZE_OBSTACLE_LOCATIONS", OA.format(key="RANDOMIZE_OBSTACLE_LOCATIONS"), H, H),
    DrfcVariable("DR_OA_IS_OBSTACLE_BOT_CAR", OA.format(key="IS_OBSTACLE_BOT_CAR"), H, H),
    DrfcVariable("DR_OA_OBSTACLE_TYPE", OA.format(key="OBSTACLE_TYPE"), H, H),
    DrfcVariable("DR_OA_OBJECT_POSITIONS", OA.format(key="OBJECT_POSITIONS") + " ('ndist,lane;...': fixed boxes "
                 "that set the count, as in DRfC)", H, H),
    DrfcVariable("DR_H2B_IS_LANE_CHANGE", H2B.format(key="IS_LANE_CHANGE"), H, H),
    DrfcVariable("DR_H2B_LOWER_LANE_CHANGE_TIME", H2B.format(key="LOWER_LANE_CHANGE_TIME"), H, H),
    DrfcVariable("DR_H2B_UPPER_LANE_CHANGE_TIME", H2B.format(key="UPPER_LANE_CHANGE_TIME"), H, H),
    DrfcVariable("DR_H2B_LANE_CHANGE_DISTANCE", H2B.format(key="LANE_CHANGE_DISTANCE"), H, H),
    DrfcVariable("DR_H2B_NUMBER_OF_BOT_CARS", H2B.format(key="NUMBER_OF_BOT_CARS"), H, H),
    DrfcVariable("DR_H2B_MIN_DISTANCE_BETWEEN_BOT_CARS", H2B.format(key="MIN_DISTANCE_BETWEEN_BOT_CARS"), H, H),
    DrfcVariable("DR_H2B_RANDOMIZE_BOT_CAR_LOCATIONS", H2B.format(key="RANDOMIZE_BOT_CAR_LOCATIONS"), H, H),
    DrfcVariable("DR_H2B_BOT_CAR_SPEED", H2B.format(key="BOT_CAR_SPEED") + " (m/s)", H, H),
    DrfcVariable("DR_H2B_BOT_CAR_PENALTY", H2B.format(key="PENALTY_SECONDS") + ": how long a bot car that ran into "
                 "the car stops", H, H),
    # system.env
    DrfcVariable("DR_CLOUD", STORE, X, X),
    DrfcVariable("DR_AWS_APP_REGION", STORE, X, X, ("",)),
    DrfcVariable("DR_UPLOAD_S3_PROFILE", UPLOAD, R, R),
    DrfcVariable("DR_UPLOAD_S3_BUCKET", UPLOAD, R, R),
    DrfcVariable("DR_LOCAL_S3_BUCKET", STORE, X, X),
    DrfcVariable("DR_LOCAL_S3_PROFILE", STORE, X, X),
    DrfcVariable("DR_GUI_ENABLE", DISPLAY, X, X, OFF),
    DrfcVariable("DR_KINESIS_STREAM_NAME", VIDEO, X, X, ("",)),
    DrfcVariable("DR_CAMERA_MAIN_ENABLE", VIDEO, X, X, OFF),
    DrfcVariable("DR_CAMERA_SUB_ENABLE", VIDEO, X, X, OFF),
    DrfcVariable("DR_CAMERA_KVS_ENABLE", VIDEO, X, X, OFF),
    DrfcVariable("DR_ENABLE_EXTRA_KVS_OVERLAY", VIDEO, X, X, OFF),
    DrfcVariable("DR_SIMAPP_SOURCE", CONTAINERS, X, X),
    DrfcVariable("DR_SIMAPP_VERSION", "--generation, the simulator racer stands in for: a 5.x SimApp is simapp5 "
                 "(ROS 1), 6.x simapp6 (ROS 2); unset (or RACER_GENERATION set), racer's default", H, H),
    DrfcVariable("DR_MINIO_IMAGE", CONTAINERS, X, X),
    DrfcVariable("DR_ANALYSIS_IMAGE", "the image of dr-start-loganalysis; racer's analysis is `racer analyze`", R, R),
    DrfcVariable("DR_WORKERS", "--workers: the number of rollout workers", H, R),
    DrfcVariable("DR_ROBOMAKER_MOUNT_LOGS", LOGS, X, X, OFF),
    DrfcVariable("DR_ROBOMAKER_MOUNT_SIMAPP_DIR", MOUNTS, X, X, ("",)),
    DrfcVariable("DR_ROBOMAKER_MOUNT_SCRIPTS_DIR", MOUNTS, X, X, ("",)),
    DrfcVariable("DR_CLOUD_WATCH_ENABLE", LOGS, X, X, OFF),
    DrfcVariable("DR_CLOUD_WATCH_LOG_STREAM_PREFIX", LOGS, X, X, ("",)),
    DrfcVariable("DR_DOCKER_STYLE", CONTAINERS, X, X),
    DrfcVariable("DR_HOST_X", DISPLAY, X, X, OFF),
    DrfcVariable("DR_WEBVIEWER_PORT", "--viewer-port: racer's live page (cameras, curves, evaluations) listens "
                 "there", H, R),
    DrfcVariable("DR_QUIET_ACTIVATE", "activate.sh's summary; racer prints none", R, R),
    DrfcVariable("DR_DISPLAY", DISPLAY, X, X, ("",)),
    DrfcVariable("DR_REMOTE_MINIO_URL", STORE, X, X, ("",)),
    DrfcVariable("DR_ROBOMAKER_CUDA_DEVICES", GPU, X, X, ("",)),
    DrfcVariable("DR_SAGEMAKER_CUDA_DEVICES", GPU, X, R, ("",)),
    DrfcVariable("DR_EXPERIMENT_NAME", "picks `experiments/<name>/` of the DRfC folder given to --drfc, as "
                 "activate.sh does; `--drfc experiments/<name>` is `activate.sh -e <name>`", H, H),
    DrfcVariable("DR_TELEGRAF_HOST", TELEGRAF, X, X, ("",)),
    DrfcVariable("DR_TELEGRAF_PORT", TELEGRAF, X, X, ("",)),
    DrfcVariable("DR_DROA_URL", DROA, R, R),
    DrfcVariable("DR_DROA_USERNAME", DROA, R, R),
    DrfcVariable("DR_DIR", "set by activate.sh, not in the files: racer sets it to the DRfC folder (the one with "
                 "system.env) for $DR_DIR references", H, H),
    # read by the prepare-config.py scripts, not in the templates
    DrfcVariable("DR_ALTERNATE_DRIVING_DIRECTION", "the older name of DR_TRAIN_ALTERNATE_DRIVING_DIRECTION, used for "
                 "worker 1 when that is unset, as DRfC", H, R),
    DrfcVariable("DR_CHANGE_START_POSITION", "the older name of DR_TRAIN_CHANGE_START_POSITION, used for worker 1 "
                 "when that is unset, as DRfC", H, R),
    DrfcVariable("DR_COLLISION_PENALTY", "--collision-penalty (COLLISION_PENALTY), seconds: the name DRfC's "
                 "evaluation reads (default 5.0), not DR_EVAL_COLLISION_PENALTY", R, H),
    DrfcVariable("DR_EVAL_OPP_S3_METRICS_PREFIX", "racer writes each car's metrics under its own model prefix", R, X,
                 ("",)),
    DrfcVariable("DR_EVAL_OPP_MODEL_PREFIX", "racer writes each car's videos under its own model prefix", R, X, ("",)),
    DrfcVariable("DR_MINIO_URL", ACTIVATE, N, N),
    DrfcVariable("DR_LOCAL_S3_ENDPOINT_URL", ACTIVATE, N, N),
    DrfcVariable("DR_LOCAL_S3_AUTH_MODE", ACTIVATE, N, N),
)  # fmt: skip

_BY_NAME = {v.name: v for v in VARIABLES}


def variable(name: str) -> DrfcVariable | None:
    return _BY_NAME.get(name)
