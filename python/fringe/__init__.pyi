# Type stubs of the fringe package (the extension module fringe._fringe re-exported).
# tests/test_stubs.py checks that every public name of the module is declared here and that
# every function declared here exists.
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

from . import evaluate as evaluate

PathLike = Union[str, os.PathLike]
Images = Union[Sequence[npt.NDArray[Any]], npt.NDArray[Any]]  # uint8/uint16 (H, W) each, or (N, H, W)
Matrix4 = npt.NDArray[np.float64]  # 4x4 rigid transform b_from_a, mm

class Error(RuntimeError):
    """Bad input, bad options, unreadable or unwritable files; the message names the file or field."""

class Camera:
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    k1: float
    k2: float
    p1: float
    p2: float
    k3: float
    def __init__(self, **fields: Any) -> None: ...
    @property
    def K(self) -> npt.NDArray[np.float64]: ...
    @staticmethod
    def reference_camera() -> Camera: ...
    @staticmethod
    def reference_projector() -> Camera: ...
    def check(self) -> None: ...
    def project(self, points_in_camera: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def unproject(self, pixels: npt.ArrayLike) -> npt.NDArray[np.float64]: ...
    def ray(self, pixels: npt.ArrayLike) -> npt.NDArray[np.float64]: ...

class Rig:
    left: Camera
    right: Camera
    projector: Optional[Camera]
    right_from_left: Matrix4
    projector_from_left: Matrix4
    def __init__(self) -> None: ...
    @property
    def baseline_mm(self) -> float: ...
    @staticmethod
    def reference() -> Rig: ...
    @staticmethod
    def load(path: PathLike) -> Rig: ...
    def save(self, path: PathLike) -> None: ...
    @staticmethod
    def from_opencv(files: Union[PathLike, Sequence[PathLike]], width: int = 0, height: int = 0) -> Rig: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def check(self) -> None: ...
    def scaled(self, scale: float) -> Rig: ...

class PointCloud:
    points: npt.NDArray[np.float64]  # (N, 3) mm
    normals: Optional[npt.NDArray[np.float64]]  # (N, 3)
    colors: Optional[npt.NDArray[np.uint8]]  # (N, 3)
    intensity: Optional[npt.NDArray[np.float32]]  # (N,)
    quality: Optional[npt.NDArray[np.float32]]  # (N,)
    residual_px: Optional[npt.NDArray[np.float32]]  # (N,) triangulation reprojection residual
    def __init__(
        self,
        points: npt.ArrayLike,
        normals: Optional[npt.ArrayLike] = None,
        colors: Optional[npt.ArrayLike] = None,
        intensity: Optional[npt.ArrayLike] = None,
        quality: Optional[npt.ArrayLike] = None,
    ) -> None: ...
    def __len__(self) -> int: ...

class Mesh:
    def __init__(self, vertices: npt.ArrayLike, triangles: npt.ArrayLike, normals: Optional[npt.ArrayLike] = None) -> None: ...
    @staticmethod
    def load(path: PathLike) -> Mesh: ...
    def save(self, path: PathLike, comments: Sequence[str] = ...) -> None: ...
    @property
    def vertices(self) -> npt.NDArray[np.float64]: ...  # (V, 3) mm
    @property
    def triangles(self) -> npt.NDArray[np.int32]: ...  # (M, 3)
    @property
    def normals(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def colors(self) -> Optional[npt.NDArray[np.uint8]]: ...

MeshLike = Union[Mesh, "PlyFile", PathLike, Tuple[npt.ArrayLike, npt.ArrayLike]]

class PlyFile:
    @property
    def cloud(self) -> PointCloud: ...
    @property
    def triangles(self) -> npt.NDArray[np.int32]: ...
    @property
    def grid_index(self) -> Optional[npt.NDArray[np.uint32]]: ...
    @property
    def grid_shape(self) -> Optional[Tuple[int, int]]: ...
    @property
    def comments(self) -> List[str]: ...
    @property
    def format(self) -> str: ...

def read_image(path: PathLike, float32: bool = False) -> npt.NDArray[Any]: ...
def write_image(path: PathLike, image: npt.NDArray[Any]) -> None: ...
def read_ply(path: PathLike) -> PlyFile: ...
@overload
def write_ply(
    path: PathLike, cloud: PointCloud, triangles: Optional[npt.ArrayLike] = None, ascii: bool = False,
    comments: Sequence[str] = ...,
) -> None: ...
@overload
def write_ply(
    path: PathLike, points: npt.ArrayLike, normals: Optional[npt.ArrayLike] = None,
    colors: Optional[npt.ArrayLike] = None, intensity: Optional[npt.ArrayLike] = None,
    quality: Optional[npt.ArrayLike] = None, triangles: Optional[npt.ArrayLike] = None,
    ascii: bool = False, comments: Sequence[str] = ...,
) -> None: ...
@overload
def write_ply(path: PathLike, view: ViewReconstruction, ascii: bool = False, comments: Sequence[str] = ...) -> None: ...

class Scheme:
    @staticmethod
    def preset(
        name: str,
        projector_width: Optional[int] = None,
        projector_height: Optional[int] = None,
        horizontal: bool = False,
        counts: Optional[Sequence[float]] = None,
        steps: Optional[int] = None,
        markers: Optional[int] = None,
        image_names: Optional[str] = None,
    ) -> Scheme: ...
    @staticmethod
    def presets() -> List[str]: ...
    @staticmethod
    def load(path: PathLike) -> Scheme: ...
    @staticmethod
    def from_dict(manifest: Dict[str, Any]) -> Scheme: ...
    def save(self, path: PathLike) -> None: ...
    def to_dict(self) -> Dict[str, Any]: ...
    @property
    def name(self) -> str: ...
    @property
    def projector_width(self) -> int: ...
    @property
    def projector_height(self) -> int: ...
    @property
    def direction(self) -> str: ...
    gamma_precompensation: float
    @property
    def periods_px(self) -> List[float]: ...
    @property
    def num_images(self) -> int: ...
    @property
    def image_names(self) -> List[str]: ...
    def check(self) -> None: ...

def patterns(scheme: Scheme, precompensate_gamma: Optional[float] = None) -> List[npt.NDArray[np.uint8]]: ...
def read_stack(dir: PathLike, scheme: Scheme) -> List[npt.NDArray[Any]]: ...

class DecodeOptions:
    noise_sigma_dn: float
    order_error_probability: float
    min_modulation_dn: float
    full_scale_dn: float
    saturation_dn: float
    min_background_fraction: float
    min_modulation_ratio: float
    max_order_residual: float
    spatial_check_fraction: float
    repair_orders: bool
    whole_stack: bool
    projector_gamma: float
    def __init__(self, **fields: Any) -> None: ...
    def check(self) -> None: ...

class DecodeResult:
    @property
    def absolute_phase(self) -> npt.NDArray[np.float32]: ...
    @property
    def wrapped_phase(self) -> npt.NDArray[np.float32]: ...
    @property
    def modulation(self) -> npt.NDArray[np.float32]: ...
    @property
    def background(self) -> npt.NDArray[np.float32]: ...
    @property
    def mask(self) -> npt.NDArray[np.bool_]: ...
    @property
    def summary(self) -> Dict[str, Any]: ...
    def brief_report(self) -> str: ...

def decode(images: Images, scheme: Scheme, options: Optional[DecodeOptions] = None, **fields: Any) -> DecodeResult: ...

class RobustLoss:
    none: RobustLoss
    huber: RobustLoss
    cauchy: RobustLoss
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class EdgeOptions:
    smoothing_sigma_px: float
    search_half_width_px: float
    min_gradient: float
    max_angle_deg: float
    def __init__(self, **fields: Any) -> None: ...

class EllipseFitOptions:
    max_iterations: int
    outlier_sigma: float
    min_outlier_dist: float
    outlier_rounds: int
    def __init__(self, **fields: Any) -> None: ...

class DetectionOptions:
    edges: EdgeOptions
    ellipse_fit: EllipseFitOptions
    min_radius_px: float
    max_radius_fraction: float
    min_axis_ratio: float
    min_convexity: float
    max_fit_rms_px: float
    min_edge_coverage: float
    max_concentricity: float
    ring_ratio_tolerance: float
    threshold_levels: int
    grid_tolerance: float
    size_tolerance: float
    def __init__(self, **fields: Any) -> None: ...

class CalibrationOptions:
    estimate_k3: bool
    estimate_tangential: bool
    max_iterations: int
    centre_rounds: int
    max_image_rms_px: float
    outlier_sigma: float
    min_features: int
    min_views: int
    loss: RobustLoss
    loss_scale_px: float
    def __init__(self, **fields: Any) -> None: ...

def calibrate(
    images_or_dir: Union[PathLike, Images, Tuple[Images, Images]], target: Target,
    detection: Union[DetectionOptions, Dict[str, Any], None] = None,
    options: Optional[CalibrationOptions] = None, **fields: Any,
) -> Tuple[Union[Rig, Camera], Dict[str, Any]]: ...

class ProjectorFeatureOptions:
    window_radius_px: int
    min_points: int
    def __init__(self, **fields: Any) -> None: ...

def calibrate_projector(
    dir: PathLike, target: Target,
    detection: Union[DetectionOptions, Dict[str, Any], None] = None,
    features: Optional[ProjectorFeatureOptions] = None,
    options: Optional[CalibrationOptions] = None, **fields: Any,
) -> Tuple[Rig, Dict[str, Any]]: ...

class CrossingInterpolation:
    linear: CrossingInterpolation
    cubic: CrossingInterpolation
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class TriangulationOptions:
    refine_iterations: int
    min_ray_angle_rad: float
    def __init__(self, **fields: Any) -> None: ...

class RectificationOptions:
    focal_scale: float
    def __init__(self, **fields: Any) -> None: ...

class MatchingOptions:
    min_modulation: float
    max_step_gradients: float
    max_reversal_gradients: float
    interpolation: CrossingInterpolation
    max_row_crossing_diff_px: float
    max_lr_error_px: float
    max_reprojection_error_px: float
    max_projector_error_px: float
    lr_warning_fraction: float
    min_depth_mm: float
    max_depth_mm: float
    triangulation: TriangulationOptions
    rectification: RectificationOptions
    def __init__(self, **fields: Any) -> None: ...

class OutlierOptions:
    max_slope_factor: float
    min_neighbours: int
    min_component_px: int
    def __init__(self, **fields: Any) -> None: ...

class GridNormalOptions:
    window_radius_px: int
    max_depth_jump_mm: float
    relative_depth_jump: float
    min_points: int
    def __init__(self, **fields: Any) -> None: ...

class ReconstructionOptions:
    decode: DecodeOptions
    matching: MatchingOptions
    remove_outliers: bool
    outliers: OutlierOptions
    compute_normals: bool
    normals: GridNormalOptions
    def __init__(self, **fields: Any) -> None: ...

class ViewReconstruction:
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def points(self) -> npt.NDArray[np.float64]: ...  # (H, W, 3), NaN where empty
    @property
    def normals(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def valid(self) -> npt.NDArray[np.bool_]: ...
    @property
    def quality(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def intensity(self) -> Optional[npt.NDArray[np.float32]]: ...
    @property
    def reprojection_error_px(self) -> npt.NDArray[np.float32]: ...
    @property
    def texture_left(self) -> npt.NDArray[np.float32]: ...
    @property
    def texture_right(self) -> npt.NDArray[np.float32]: ...
    @property
    def summary(self) -> Dict[str, Any]: ...
    @property
    def ok(self) -> bool: ...
    def cloud(self) -> PointCloud: ...
    def brief_report(self) -> str: ...

class Reconstructor:
    def __init__(self, rig: Rig, scheme: Scheme, options: Optional[ReconstructionOptions] = None, **fields: Any) -> None: ...
    def reconstruct(self, left: Images, right: Images) -> ViewReconstruction: ...

def reconstruct(
    rig: Rig, scheme: Scheme, left: Images, right: Optional[Images] = None,
    options: Optional[ReconstructionOptions] = None, **fields: Any,
) -> ViewReconstruction:
    """Stereo (left and right stacks) or, with right=None, camera-projector mode."""

def reconstruct_camera_projector(
    rig: Rig, schemes: List[Scheme], stacks: List[Images],
    options: Optional[ReconstructionOptions] = None, **fields: Any,
) -> ViewReconstruction:
    """The left camera against the rig's projector; one stack per scheme (one or two directions)."""

class VdiOptions:
    discard_fraction: float
    inlier_band_mm: float
    ransac_iterations: int
    seed: int
    ransac_sample_points: int
    radius_tolerance: float
    min_points: int
    def __init__(self, **fields: Any) -> None: ...

def deviation(
    points: Union[npt.ArrayLike, PointCloud],
    mesh: MeshLike,
    max_distance_mm: float = 2.0,
) -> Tuple[Dict[str, Any], npt.NDArray[np.float64]]: ...

class TargetType:
    rings: TargetType
    circles: TargetType
    asymmetric_circles: TargetType
    chessboard: TargetType
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class Target:
    type: TargetType
    rows: int
    cols: int
    spacing_mm: float
    outer_radius_mm: float
    inner_radius_mm: float
    dot_radius_mm: float
    margin_mm: float
    distinct_features: List[Tuple[int, int]]
    def __init__(self, **fields: Any) -> None: ...
    @staticmethod
    def load(path: PathLike) -> Target: ...
    def save(self, path: PathLike) -> None: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def check(self) -> None: ...

class SensorOptions:
    supersampling: int
    exposure: float
    bit_depth: int
    noise: bool
    read_noise_dn: float
    shot_noise: bool
    electrons_per_dn: float
    defocus_sigma_px: float
    float_output: bool
    seed: int
    def __init__(self, **fields: Any) -> None: ...

class ProjectorOptions:
    gamma: float
    black_level: float
    brightness: float
    ambient: float
    defocus_sigma_px: float
    pixelated: bool
    def __init__(self, **fields: Any) -> None: ...

class RenderOptions:
    sensor: SensorOptions
    projector: ProjectorOptions
    truth: bool
    shadow_offset_mm: float
    marker_visibility_tolerance_mm: float
    def __init__(self, **fields: Any) -> None: ...

class BoardRenderOptions:
    sensor: SensorOptions
    edge_supersampling: int
    white_albedo: float
    black_albedo: float
    background_albedo: float
    illumination: float
    def __init__(self, **fields: Any) -> None: ...

class OrbitOptions:
    views: int
    turntable: bool
    elevation_deg: float
    elevation_jitter_deg: float
    azimuth_start_deg: float
    azimuth_jitter_deg: float
    roll_jitter_deg: float
    standoff_jitter_mm: float
    seed: int
    def __init__(self, **fields: Any) -> None: ...

class BoardPoseOptions:
    count: int
    min_distance_mm: float
    max_distance_mm: float
    max_tilt_deg: float
    max_roll_deg: float
    min_visible_fraction: float
    both_cameras: bool
    seed: int
    def __init__(self, **fields: Any) -> None: ...

class ScanOptions:
    scene: str
    views: int
    seed: int
    scheme: Optional[Scheme]  # None: heterodyne-4x3 for the rig's projector, not pre-compensated
    calibration_images: int
    target: Target
    truth_maps: bool
    render: RenderOptions
    board: BoardRenderOptions
    orbit: OrbitOptions
    board_poses: BoardPoseOptions
    def __init__(self, **fields: Any) -> None: ...

class SimulatedView:
    @property
    def left(self) -> List[npt.NDArray[Any]]: ...
    @property
    def right(self) -> List[npt.NDArray[Any]]: ...
    @property
    def left_truth(self) -> Optional[Dict[str, npt.NDArray[Any]]]: ...
    @property
    def right_truth(self) -> Optional[Dict[str, npt.NDArray[Any]]]: ...
    @property
    def world_from_sensor(self) -> Matrix4: ...
    @property
    def markers(self) -> List[Dict[str, Any]]: ...

class Simulator:
    def __init__(self, rig: Optional[Rig] = None, options: Optional[ScanOptions] = None, **fields: Any) -> None: ...
    @property
    def rig(self) -> Rig: ...
    @property
    def scheme(self) -> Scheme: ...
    @property
    def patterns(self) -> List[npt.NDArray[np.uint8]]: ...
    @property
    def views(self) -> int: ...
    @property
    def calibration_images(self) -> int: ...
    @property
    def view_poses(self) -> List[Matrix4]: ...
    def render_view(self, view: int) -> SimulatedView: ...
    def render_board(self, index: int) -> Tuple[Dict[str, Any], Dict[str, Any]]: ...

def simulate_projector_calibration(
    out: PathLike, rig: Rig, target: Target, poses: int = 5, seed: int = 1,
    two_cameras: bool = False, supersampling: int = 1, preset: str = "heterodyne-4x3",
) -> List[Matrix4]: ...

def simulate(rig: Optional[Rig] = None, options: Optional[ScanOptions] = None, **fields: Any) -> List[SimulatedView]: ...
def simulate_scan(out: PathLike, rig: Optional[Rig] = None, options: Optional[ScanOptions] = None, **fields: Any) -> Dict[str, Any]: ...
def scene_names() -> List[str]: ...

class ScannerOptions:
    calib: PathLike
    opencv: List[PathLike]
    opencv_keys: List[str]
    opencv_intrinsics: PathLike
    opencv_extrinsics: PathLike
    keep_going: bool
    resume: bool
    views_in_flight: int
    memory_limit_gib: float
    fusion_tile_mm: float
    reconstruction: ReconstructionOptions
    detect_markers: bool
    markers: MarkerDetectionOptions
    fit_projector_columns: bool
    registration: RegistrationOptions
    fusion: FusionOptions
    mesh: MeshOptions
    evaluate_truth: bool
    write_report: bool
    def __init__(self, **fields: Any) -> None: ...

def scan(project: PathLike, out: PathLike, options: Optional[ScannerOptions] = None, **fields: Any) -> Dict[str, Any]: ...

class ReconstructFolderOptions:
    calib: PathLike
    opencv: List[PathLike]
    opencv_keys: List[str]
    opencv_intrinsics: PathLike
    opencv_extrinsics: PathLike
    mode: str  # auto, stereo, camera-projector, trinocular
    scheme: str
    bit_depth: int
    reconstruction: ReconstructionOptions
    detect_markers: bool
    ascii_ply: bool
    residuals: PathLike
    def __init__(self, **fields: Any) -> None: ...

def reconstruct_folder(view: PathLike, out: PathLike, options: Optional[ReconstructFolderOptions] = None, **fields: Any) -> Dict[str, Any]: ...

class MarkerDetectionOptions:
    rings: DetectionOptions
    inner_to_outer_ratio: float
    max_epipolar_px: float
    max_depth_difference_mm: float
    relative_depth_difference: float
    min_outer_radius_mm: float
    max_outer_radius_mm: float
    surface_radius_factor: float
    min_surface_points: int
    def __init__(self, **fields: Any) -> None: ...

class ViewMarker:
    @property
    def id(self) -> int: ...
    @property
    def centre_in_sensor(self) -> npt.NDArray[np.float64]: ...
    @property
    def normal_in_sensor(self) -> npt.NDArray[np.float64]: ...
    @property
    def left_px(self) -> npt.NDArray[np.float64]: ...
    @property
    def right_px(self) -> npt.NDArray[np.float64]: ...
    @property
    def outer_radius_mm(self) -> float: ...
    @property
    def sigma_mm(self) -> float: ...
    @property
    def depth_difference_mm(self) -> float: ...

def detect_markers(
    rig: Rig, view: ViewReconstruction, options: Optional[MarkerDetectionOptions] = None, **fields: Any
) -> Tuple[List[ViewMarker], str]: ...
def read_markers(path: PathLike) -> List[ViewMarker]: ...
def write_markers(path: PathLike, markers: Sequence[ViewMarker]) -> None: ...

class MarkerMatchOptions:
    distance_tolerance_mm: float
    sigma_factor: float
    max_normal_angle_deg: float
    min_matches: int
    ambiguity_margin: int
    same_pose_deg: float
    same_pose_mm: float
    outlier_rounds: int
    def __init__(self, **fields: Any) -> None: ...

class AdjustmentOptions:
    huber_sigmas: float
    max_iterations: int
    def __init__(self, **fields: Any) -> None: ...

class CoarseOptions:
    voxel_mm: float
    feature_radius_factor: float
    max_ransac_iterations: int
    ransac_confidence: float
    min_fitness: float
    seed: int
    def __init__(self, **fields: Any) -> None: ...

class IcpOptions:
    points_per_level: List[int]
    max_iterations_per_level: int
    initial_threshold_mm: float
    min_threshold_mm: float
    shrink_factor: float
    shrink_percentile: float
    trim_fraction: float
    max_normal_angle_deg: float
    min_overlap_fraction: float
    degeneracy_ratio: float
    convergence_rotation_deg: float
    convergence_translation_mm: float
    seed: int
    def __init__(self, **fields: Any) -> None: ...

class PoseGraphOptions:
    max_cycle_deg: float
    max_cycle_mm: float
    def __init__(self, **fields: Any) -> None: ...

class RegistrationOptions:
    use_markers: bool
    coarse_fallback: bool
    adjust_markers: bool
    refine_icp: bool
    min_extent_mm: float
    icp_threshold_factor: float
    icp_min_start_threshold_mm: float
    coarse_verify_min_overlap: float
    coarse_verify_tolerance_factor: float
    coarse_max_inconsistent: float
    coarse_max_free_space: float
    coarse_min_gap: float
    coarse_same_pose_deg: float
    coarse_same_pose_mm: float
    matching: MarkerMatchOptions
    pose_graph: PoseGraphOptions
    adjustment: AdjustmentOptions
    coarse: CoarseOptions
    icp: IcpOptions
    def __init__(self, **fields: Any) -> None: ...

class RegistrationResult:
    @property
    def names(self) -> List[str]: ...
    @property
    def world_from_sensor(self) -> List[Optional[Matrix4]]: ...
    @property
    def placed(self) -> List[bool]: ...
    @property
    def paths(self) -> List[str]: ...
    @property
    def ok(self) -> bool: ...
    @property
    def summary(self) -> Dict[str, Any]: ...
    def save_poses(self, path: PathLike) -> None: ...
    def brief_report(self) -> str: ...

def register(
    views: Sequence[Union[PathLike, ViewReconstruction, PointCloud]],
    names: Optional[Sequence[str]] = None,
    markers: Optional[Sequence[Optional[Sequence[ViewMarker]]]] = None,
    initial: Optional[Sequence[Optional[npt.ArrayLike]]] = None,
    scale_to_mm: float = 1.0,
    options: Optional[RegistrationOptions] = None,
    **fields: Any,
) -> RegistrationResult: ...

class FusionOptions:
    spacing_factor: float
    seed_factor: float
    border_seed_factor: float
    border_seed_px: int
    registration_rms_mm: float
    registration_factor: float
    max_normal_angle_deg: float
    lateral_sigma: float
    max_disagreement: float
    max_iterations: int
    convergence_mm: float
    max_moving_fraction: float
    modulation_half_dn: float
    residual_half_px: float
    min_cos_view: float
    border_ramp_px: int
    border_trim_px: int
    one_view_cluster_border_px: int
    smooth_radius_px: int
    min_border_hole_px: int
    max_fit_error_px: float
    max_spacing_ratio: float
    def __init__(self, **fields: Any) -> None: ...

class FusionResult:
    @property
    def cloud(self) -> PointCloud: ...
    @property
    def support(self) -> npt.NDArray[np.uint16]: ...
    @property
    def overlap(self) -> List[npt.NDArray[np.uint8]]: ...
    @property
    def ok(self) -> bool: ...
    @property
    def summary(self) -> Dict[str, Any]: ...
    def brief_report(self) -> str: ...

def fuse(
    views: Sequence[Union[PathLike, ViewReconstruction]],
    poses: Union[RegistrationResult, Sequence[npt.ArrayLike]],
    names: Optional[Sequence[str]] = None,
    options: Optional[FusionOptions] = None,
    **fields: Any,
) -> FusionResult: ...

class MeshLibrary:
    open3d: MeshLibrary
    cgal: MeshLibrary
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...

class MeshOptions:
    library: MeshLibrary
    poisson_depth: int
    cell_spacings: float
    resolution_mm: float
    max_auto_depth: int
    watertight: bool
    trim_density_quantile: float
    trim_distance_factor: float
    max_surface_cells: int
    project_to_points: bool
    project_neighbours: int
    max_project_flatness: float
    max_project_spacings: float
    max_triangles: int
    threads: int
    poisson_pieces: int
    min_cells_per_piece: int
    piece_margin_cells: int
    max_seam_unmatched: float
    def __init__(self, **fields: Any) -> None: ...

class MeshResult:
    @property
    def mesh(self) -> Mesh: ...
    @property
    def ok(self) -> bool: ...
    @property
    def summary(self) -> Dict[str, Any]: ...
    def brief_report(self) -> str: ...

def mesh(cloud: Union[PointCloud, FusionResult], options: Optional[MeshOptions] = None, **fields: Any) -> MeshResult: ...
