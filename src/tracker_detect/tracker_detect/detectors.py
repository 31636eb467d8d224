"""The detector registry: the detector node's `method` parameter picks one of these (no rclpy).

Each method is a `tracker_msgs_py.registry.Method` whose `build(values)` returns a
`detector.Detector`. To add a detector, write its module (a class satisfying `detector.Detector`)
and register it here with one `DETECTORS.register(Method(...))` line. The contract every
registered detector keeps is checked by tests/detect/test_detector_contract.py.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import replace
from typing import Any

from tracker_detect.background import BackgroundConfig, BackgroundDetector
from tracker_detect.camshift import CamShiftConfig, CamShiftTracker
from tracker_detect.detector import CameraFrame, Detection, Detector
from tracker_detect.fusion import FusionConfig, FusionDetector
from tracker_detect.mog2 import Mog2Config, Mog2Detector
from tracker_detect.motion import (
    COMPENSATION_MODES,
    ESTIMATORS,
    KERNEL_SHAPES,
    MORPHOLOGY_STEPS,
    SEED_MORPHOLOGY,
    DetectorConfig,
    MotionDetector,
)
from tracker_detect.person import MODEL_FILES, RUNTIMES, PersonConfig, PersonDetector
from tracker_msgs_py.params import ParamSpec, config_from_params
from tracker_msgs_py.registry import Method, Registry

DETECTORS: Registry[Detector] = Registry("detector")
#: Entry-point group other packages declare their detector `Method`s in (loaded by the node).
PLUGIN_GROUP = "tracker_suite.detectors"

_D = DetectorConfig()

SSIM_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("gap", _D.gap, "frames between the compared images (seed: 3)", 1, 100),
    ParamSpec("threshold", _D.threshold, "SSIM at or below which a pixel is motion", -1.0, 1.0),
    ParamSpec(
        "morphology",
        list(SEED_MORPHOLOGY),
        "mask clean-up steps in order, each one of: " + ", ".join(MORPHOLOGY_STEPS),
        validator=lambda v: (
            None
            if all(s in MORPHOLOGY_STEPS for s in v)
            else f"morphology steps must be among {', '.join(MORPHOLOGY_STEPS)}"
        ),
    ),
    ParamSpec(
        "kernel_shape",
        _D.kernel_shape,
        "dilation element ('seed' = the thesis' 7x7 H)",
        choices=KERNEL_SHAPES,
    ),
    ParamSpec(
        "kernel_size",
        _D.kernel_size,
        "odd side of the element for shapes other than 'seed' [px]",
        1,
        51,
        validator=lambda v: None if v % 2 else "kernel_size must be odd",
    ),
    ParamSpec(
        "connectivity",
        _D.connectivity,
        "blob pixel connectivity (4 or 8)",
        4,
        8,
        validator=lambda v: None if v in (4, 8) else "connectivity must be 4 or 8",
    ),
    ParamSpec(
        "presence_fraction",
        _D.presence_fraction,
        "presence test: total blob area >= this fraction of the compared area",
        0.0,
        1.0,
    ),
    ParamSpec(
        "min_blob_area", _D.min_blob_area, "drop blobs smaller than this [scene px^2]", 0.0, 1e9
    ),
    ParamSpec(
        "compensation",
        _D.compensation,
        "ego-motion compensation: known (from the poses), ssim_search (seed's exhaustive "
        "simplified-SSIM search), phase_correlation, off",
        choices=COMPENSATION_MODES,
    ),
    ParamSpec("search_radius", _D.search_radius, "shift estimators search +- this [px]", 0, 200),
    ParamSpec(
        "search_window", _D.search_window, "uniform window of the simplified SSIM [px]", 1, 31
    ),
    ParamSpec(
        "search_pyramid_levels",
        _D.search_pyramid_levels,
        "coarse-to-fine levels of ssim_search (0 = the seed's full-resolution search)",
        0,
        5,
    ),
    ParamSpec(
        "phase_candidates",
        _D.phase_candidates,
        "phase_correlation: peaks verified by the simplified SSIM",
        1,
        50,
    ),
    ParamSpec(
        "subpixel_alignment",
        _D.subpixel_alignment,
        "resample fractional shifts bilinearly (else round them)",
    ),
    ParamSpec(
        "auto_downsample",
        _D.auto_downsample,
        "Wang's automatic downsampling, f = round(min(H, W) / 256)",
    ),
    ParamSpec(
        "min_overlap_fraction",
        _D.min_overlap_fraction,
        "compare only when the aligned images overlap at least this much",
        0.01,
        1.0,
    ),
    ParamSpec(
        "double_detection",
        _D.double_detection,
        "also compare with the frame where motion began (slow / stopped objects)",
    ),
    ParamSpec(
        "reference_max_age",
        _D.reference_max_age,
        "frames a double-detection reference is kept at most",
        1,
        100000,
    ),
)


class SsimDetector:
    """Seed 000's SSIM motion detection (`motion.MotionDetector`) as a `Detector`."""

    def __init__(self, config: DetectorConfig) -> None:
        self.motion = MotionDetector(config)

    @property
    def config(self) -> DetectorConfig:
        return self.motion.config

    @property
    def estimates_ego_motion(self) -> bool:
        return self.motion.config.compensation in ESTIMATORS

    def process(self, frame: CameraFrame) -> Detection:
        return self.motion.process(frame.gray, frame.stamp_ns, frame.view)

    def reset(self) -> None:
        self.motion.reset()

    def reconfigure(self, values: Mapping[str, Any]) -> None:
        """New parameter values from the next frame on, keeping the history it can."""
        self.motion.reconfigure(ssim_config(values))


def ssim_config(values: Mapping[str, Any]) -> DetectorConfig:
    """The DetectorConfig the SSIM parameters describe (raises ValueError when invalid)."""
    return config_from_params(DetectorConfig, values, morphology=tuple(values["morphology"]))


DETECTORS.register(
    Method(
        name="ssim",
        description="SSIM change detection between frames `gap` apart after ego-motion "
        "compensation, morphology, connected blobs (seed 000)",
        build=lambda values: SsimDetector(ssim_config(values)),
        parameters=SSIM_PARAMETERS,
    )
)


_B = BackgroundConfig()
_SSIM_SPECS = {spec.name: spec for spec in SSIM_PARAMETERS}


def _like_ssim(name: str, default: Any) -> ParamSpec:
    """The `ssim` method's parameter of that name (range, validator, meaning) with this default."""
    return replace(_SSIM_SPECS[name], default=default)


BACKGROUND_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec("threshold", _B.threshold, "SSIM at or below which a pixel is foreground", -1.0, 1.0),
    ParamSpec("gap", _B.gap, "frames to the image that tells moving from still pixels", 1, 100),
    ParamSpec(
        "learning_rate", _B.learning_rate, "background blend rate where nothing differs", 0.0, 1.0
    ),
    ParamSpec(
        "heal_rate",
        _B.heal_rate,
        "background blend rate where the view differs but does not change (ghosts, stopped "
        "objects)",
        0.0,
        1.0,
    ),
    ParamSpec(
        "stopped_heal_rate",
        _B.stopped_heal_rate,
        "background blend rate where the view differs but does not change, on a blob whose "
        "outline is an edge of the view and not of the background (a stopped object, not a "
        "ghost); below heal_rate it stays foreground longer",
        0.0,
        1.0,
    ),
    ParamSpec(
        "warmup_observations",
        _B.warmup_observations,
        "a scene pixel's first observations are averaged",
        1,
        100000,
    ),
    ParamSpec(
        "min_observations",
        _B.min_observations,
        "a pixel is judged once the background has seen it this often",
        1,
        100000,
    ),
    ParamSpec(
        "flicker_observations",
        _B.flicker_observations,
        "the flicker rate is trusted once a pixel was seen this often",
        1,
        100000,
    ),
    ParamSpec(
        "flicker_memory", _B.flicker_memory, "time constant of the flicker rate [frames]", 1.0, 1e6
    ),
    ParamSpec(
        "flicker_level",
        _B.flicker_level,
        "flicker rate (share of frames foreground and changing) from which a pixel moves in "
        "place and is ignored",
        0.0,
        1.0,
    ),
    ParamSpec(
        "close_size",
        _B.close_size,
        "side of the elliptic closing element [px] (1: none)",
        1,
        51,
        validator=lambda v: None if v % 2 else "close_size must be odd",
    ),
    ParamSpec(
        "shrink_size",
        _B.shrink_size,
        "side of the elliptic erosion undoing the SSIM window's spread [px] (1: none)",
        1,
        51,
        validator=lambda v: None if v % 2 else "shrink_size must be odd",
    ),
    _like_ssim("connectivity", _B.connectivity),
    _like_ssim("min_blob_area", _B.min_blob_area),
    ParamSpec(
        "min_aspect",
        _B.min_aspect,
        "drop blobs flatter than this height / width (0: keep all; people stand, tape lies)",
        0.0,
        10.0,
    ),
    ParamSpec(
        "shadow_ratio",
        _B.shadow_ratio,
        "ignore cast shadows: pixels darkened to between this and 0.95 of the background's "
        "brightness that keep its colour (colour images only; 0: off)",
        0.0,
        0.94,
    ),
    ParamSpec(
        "register_reach",
        _B.register_reach,
        "align each view with the background mosaic by phase correlation, up to this far [px], "
        "when the camera shakes more than its pose reports (0: trust the pose)",
        0,
        64,
    ),
    _like_ssim("presence_fraction", _B.presence_fraction),
    _like_ssim("auto_downsample", _B.auto_downsample),
)


class SsimBackground:
    """`background.BackgroundDetector` with live reconfiguration from parameter values."""

    def __init__(self, config: BackgroundConfig) -> None:
        self.detector = BackgroundDetector(config)

    estimates_ego_motion = False

    def process(self, frame: CameraFrame) -> Detection:
        return self.detector.process(frame)

    def learn_last_frame(self) -> None:
        self.detector.learn_last_frame()

    def reset(self) -> None:
        self.detector.reset()

    def reconfigure(self, values: Mapping[str, Any]) -> None:
        self.detector.reconfigure(config_from_params(BackgroundConfig, values))


DETECTORS.register(
    Method(
        name="ssim_background",
        description="SSIM against a background mosaic kept in scene coordinates, with a learned "
        "flicker map; object silhouettes, undilated boxes (issue 11)",
        build=lambda values: SsimBackground(config_from_params(BackgroundConfig, values)),
        parameters=BACKGROUND_PARAMETERS,
    )
)


_C = CamShiftConfig()

CAMSHIFT_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "hue_bins", _C.hue_bins, "bins of the hue histogram over [0, 180) (seed: 32)", 2, 180
    ),
    ParamSpec(
        "saturation_bins",
        _C.saturation_bins,
        "0: a hue histogram (seed); else also this many saturation bins (a hue x saturation one)",
        0,
        256,
    ),
    ParamSpec(
        "background_weighting",
        _C.background_weighting,
        "down-weight the colours of the selection's surroundings (Comaniciu's background-"
        "weighted histogram; false: the seed's plain histogram)",
    ),
    ParamSpec(
        "background_margin",
        _C.background_margin,
        "surroundings: the selection grown by this x its size on each side",
        0.05,
        10.0,
    ),
    ParamSpec("v_min", _C.v_min, "pixels darker than this are ignored (seed: 10)", 0, 256),
    ParamSpec("v_max", _C.v_max, "pixels brighter than this are ignored (seed: 256)", 0, 256),
    ParamSpec("s_min", _C.s_min, "pixels less saturated than this are ignored (seed: 30)", 0, 255),
    ParamSpec("max_iterations", _C.max_iterations, "mean-shift steps per frame at most", 1, 100),
    ParamSpec(
        "epsilon", _C.epsilon, "mean shift stops when the window moves less [px]", 0.01, 100.0
    ),
    ParamSpec(
        "search_margin",
        _C.search_margin,
        "search region: the window grown by this x its size on each side",
        0.0,
        10.0,
    ),
    ParamSpec(
        "min_density_ratio",
        _C.min_density_ratio,
        "a found box whose mean back-projection is below this x the selection's is a miss",
        0.0,
        1.0,
    ),
    ParamSpec(
        "lost_after",
        _C.lost_after,
        "consecutive misses after which the whole image is searched (re-acquisition)",
        1,
        100000,
    ),
    ParamSpec(
        "max_size_ratio",
        _C.max_size_ratio,
        "a box larger than this x the selection's side is a miss (spread over the background)",
        1.01,
        100.0,
    ),
    ParamSpec(
        "min_model_pixels",
        _C.min_model_pixels,
        "coloured pixels (passing the S/V limits) a selection needs",
        1,
        1_000_000,
    ),
    ParamSpec(
        "min_contrast",
        _C.min_contrast,
        "a selection whose mean back-projection is below this x its surroundings' is refused: its "
        "colours do not stand out (0: no check)",
        0.0,
        1000.0,
    ),
    ParamSpec(
        "min_similarity",
        _C.min_similarity,
        "a found box whose colours match the model's less (Bhattacharyya coefficient of the "
        "plain histograms) is a miss: CamShift slid onto a like-coloured background (0: no check)",
        0.0,
        1.0,
    ),
    ParamSpec(
        "rehandover_similarity",
        _C.rehandover_similarity,
        "while tracking, a handed-over box apart from the tracked one is taken when its colours "
        "match the model at least this well (Bhattacharyya) and better than the tracked box's "
        "(0: never)",
        0.0,
        1.0,
    ),
)


class CamShift(CamShiftTracker):
    """`camshift.CamShiftTracker` with reconfiguration from parameter values."""

    def reconfigure(self, values: Mapping[str, Any]) -> None:  # type: ignore[override]
        super().reconfigure(config_from_params(CamShiftConfig, values))


DETECTORS.register(
    Method(
        name="camshift",
        description="CamShift colour tracking of one target started from a rectangle "
        "(select_region) or handed over from a tracked target; prediction-guided search, "
        "loss and re-acquisition (seed 001)",
        build=lambda values: CamShift(config_from_params(CamShiftConfig, values)),
        parameters=CAMSHIFT_PARAMETERS,
    )
)


_M = Mog2Config()

MOG2_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "equalize",
        _M.equalize,
        "histogram-equalise the image first (the grey image, or each colour channel)",
    ),
    ParamSpec(
        "colour",
        _M.colour,
        "model the colour image (a grey one replicated); false: the grey image, as the thesis "
        "(MOG2's shadow test then takes any pixel darkened to 50-100 % for a shadow)",
    ),
    ParamSpec("history", _M.history, "frames of MOG2's history (OpenCV: 500)", 1, 100000),
    ParamSpec(
        "var_threshold",
        _M.var_threshold,
        "squared Mahalanobis distance within which a pixel matches a background mode (OpenCV: 16)",
        0.01,
        10000.0,
    ),
    ParamSpec(
        "detect_shadows", _M.detect_shadows, "MOG2's shadow pixels are background, not objects"
    ),
    ParamSpec(
        "learning_rate",
        _M.learning_rate,
        "model learning rate per frame (negative: OpenCV's automatic 1 / min(2 n, history))",
        -1.0,
        1.0,
    ),
    ParamSpec(
        "dilate_radius",
        _M.dilate_radius,
        "radius of the diamond the mask is dilated with [px] (seed: 4; 0: none)",
        0,
        50,
    ),
    ParamSpec(
        "close_size",
        _M.close_size,
        "side of the square the dilated mask is closed with [px] (seed: 2; 1: none)",
        1,
        51,
    ),
    _like_ssim("min_blob_area", _M.min_blob_area),
    ParamSpec(
        "warmup_frames",
        _M.warmup_frames,
        "frames after a (re)start of the model that are learned, not compared",
        1,
        100000,
    ),
    _like_ssim("presence_fraction", _M.presence_fraction),
)


class Mog2(Mog2Detector):
    """`mog2.Mog2Detector` with reconfiguration from parameter values."""

    def reconfigure(self, values: Mapping[str, Any]) -> None:  # type: ignore[override]
        super().reconfigure(config_from_params(Mog2Config, values))


DETECTORS.register(
    Method(
        name="mog2",
        description="OpenCV MOG2 background subtraction for a static camera, dilate (diamond 4) "
        "+ close (2x2), 8-connected blobs of small objects (seed 004)",
        build=lambda values: Mog2(config_from_params(Mog2Config, values)),
        parameters=MOG2_PARAMETERS,
    )
)


_P = PersonConfig()

PERSON_PARAMETERS: tuple[ParamSpec, ...] = (
    ParamSpec(
        "input_size",
        _P.input_size,
        "the model input's longer side [px] (a multiple of 32; the image is scaled to it)",
        32,
        2048,
        validator=lambda v: None if v % 32 == 0 else "input_size must be a multiple of 32",
    ),
    ParamSpec(
        "score_threshold", _P.score_threshold, "person score below which a box is dropped", 0.0, 1.0
    ),
    ParamSpec(
        "nms_iou", _P.nms_iou, "boxes overlapping more than this IoU are one person", 0.01, 1.0
    ),
    ParamSpec("threads", _P.threads, "the runtime's threads per image", 1, 64, read_only=True),
    ParamSpec(
        "runtime",
        _P.runtime,
        "onnxruntime, or opencv (OpenCV's DNN: a fallback giving the same boxes)",
        choices=RUNTIMES,
        read_only=True,
    ),
    ParamSpec(
        "precision",
        _P.precision,
        "the shipped NanoDet's: int8 (quantised, about twice as fast on a CPU) or float32",
        choices=tuple(MODEL_FILES),
        read_only=True,
    ),
    ParamSpec(
        "model_path",
        _P.model_path,
        "an ONNX person model of NanoDet's layout ('' = the shipped NanoDet of `precision`)",
        read_only=True,
    ),
)

DETECTORS.register(
    Method(
        name="person",
        description="a learned person model (NanoDet, COCO's person class, onnxruntime) on each "
        "camera image: person boxes with scores",
        build=lambda values: PersonDetector(config_from_params(PersonConfig, values)),
        parameters=PERSON_PARAMETERS,
    )
)


_F = FusionConfig()
#: The person model keeps its weak boxes here: the tracker's second association stage uses them.
FUSION_SCORE_THRESHOLD = 0.2

FUSION_PARAMETERS: tuple[ParamSpec, ...] = (
    BACKGROUND_PARAMETERS
    + tuple(
        replace(spec, default=FUSION_SCORE_THRESHOLD) if spec.name == "score_threshold" else spec
        for spec in PERSON_PARAMETERS
    )
    + (
        ParamSpec(
            "explained_share",
            _F.explained_share,
            "a motion blob whose box person boxes cover at least this share is those people's "
            "(else it is published labelled motion)",
            0.01,
            1.0,
        ),
        ParamSpec(
            "motion_blobs", _F.motion_blobs, "publish the blobs no person explains (label motion)"
        ),
        ParamSpec(
            "motion_share",
            _F.motion_share,
            "share of a person box's pixels in the motion mask that vouches for it",
            0.0,
            1.0,
        ),
        ParamSpec(
            "still_score",
            _F.still_score,
            "score cap of a person box motion does not vouch for (below the tracker's high: it "
            "continues a track, never starts one; 1: no cap)",
            0.0,
            1.0,
        ),
    )
)


def _fusion(values: Mapping[str, Any]) -> FusionDetector:
    return FusionDetector(
        config_from_params(BackgroundConfig, values),
        config_from_params(PersonConfig, values),
        config_from_params(FusionConfig, values),
    )


DETECTORS.register(
    Method(
        name="person_motion",
        description="motion proposes, the person model decides: the SSIM background detector's "
        "blobs and the person model's boxes on each camera image; person boxes labelled person, "
        "blobs no person explains labelled motion",
        build=_fusion,
        parameters=FUSION_PARAMETERS,
    )
)
