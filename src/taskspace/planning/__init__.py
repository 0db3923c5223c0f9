"""Path planning (lecture section 3): bugs, potential fields, grids, graphs, curves, PRMs, RRTs.

Optimal planners (RRT*, informed RRT*, PRM*, Lazy PRM*, BIT*) take an
:class:`OptimizationObjective`; every sampling-based planner follows one limit convention
(:mod:`taskspace.planning.limits`).
"""

from taskspace.planning.bit_star import BITStarOptions, bit_star
from taskspace.planning.bug import BugOptions, BugResult, BugStatus, bug1, bug2
from taskspace.planning.car import CarModel, ControlSamplingOptions, ControlTree, grow_control_tree
from taskspace.planning.certify import (
    MotionBound,
    PathCertificate,
    certify_path,
    motion_bound,
    motion_bounds,
)
from taskspace.planning.collision_checker import (
    CollisionChecker,
    CollisionCheckerOptions,
    FunctionChecker,
)
from taskspace.planning.configuration_space import (
    ConfigurationSpace,
    EdgeCheckOptions,
    bisection_order,
    path_length,
)
from taskspace.planning.dubins import dubins_distance, dubins_paths, dubins_shortest
from taskspace.planning.goals import GoalRegion
from taskspace.planning.graph_search import (
    GraphSearchOptions,
    GraphSearchResult,
    SearchStatus,
    astar,
    dijkstra,
)
from taskspace.planning.grid import (
    GridPathResult,
    GridSearchOptions,
    GridStatus,
    OccupancyGrid,
    WavefrontResult,
    grid_search,
    wavefront,
    wavefront_path,
)
from taskspace.planning.joint_manifold import JointManifold
from taskspace.planning.kinodynamic_rrt import (
    KinodynamicRRTOptions,
    KinodynamicRRTResult,
    RRTStatus,
    kinodynamic_rrt,
    parking_lot,
)
from taskspace.planning.lazy_prm import LazyRoadmap, build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.limits import planner_limits
from taskspace.planning.locked_joints import LockedJointChecker, LockedJoints
from taskspace.planning.nearest import GrowingNearest
from taskspace.planning.objectives import (
    Clearance,
    MechanicalWork,
    MetricLength,
    OptimizationObjective,
    PathLength,
    WeightedSum,
)
from taskspace.planning.planner_result import PlannerResult, PlannerStatus, Tree
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    PotentialFieldResult,
    PotentialStatus,
    gradient_descent,
)
from taskspace.planning.prm import (
    PRMOptions,
    Roadmap,
    build_prm,
    check_roadmap_world,
    prm,
    prm_query,
)
from taskspace.planning.prm_star import PRMStarOptions, lazy_prm_star, prm_star
from taskspace.planning.reeds_shepp import (
    reeds_shepp_distance,
    reeds_shepp_paths,
    reeds_shepp_shortest,
)
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
from taskspace.planning.rrt_star import RRTStarOptions, interpolate, rrt_star
from taskspace.planning.sampling import sample_free
from taskspace.planning.scene_loader import (
    MOTIONBENCHMAKER_SCENARIOS,
    load_moveit_request,
    load_moveit_scene,
    motionbenchmaker_dir,
    motionbenchmaker_panda,
    motionbenchmaker_problems,
)
from taskspace.planning.se2 import CurvePath, angle_distance, se2_distance, wrap_angle
from taskspace.planning.shortcut import ShortcutOptions, ShortcutResult, shortcut_path
from taskspace.planning.smoothing import SmoothingOptions, SmoothingResult, smooth_bspline

__all__ = [
    "MOTIONBENCHMAKER_SCENARIOS",
    "BITStarOptions",
    "BugOptions",
    "BugResult",
    "BugStatus",
    "CarModel",
    "Clearance",
    "CollisionChecker",
    "CollisionCheckerOptions",
    "ConfigurationSpace",
    "ControlSamplingOptions",
    "ControlTree",
    "CurvePath",
    "EdgeCheckOptions",
    "FunctionChecker",
    "GoalRegion",
    "GraphSearchOptions",
    "GraphSearchResult",
    "GridPathResult",
    "GridSearchOptions",
    "GridStatus",
    "GrowingNearest",
    "JointManifold",
    "KinodynamicRRTOptions",
    "KinodynamicRRTResult",
    "LazyRoadmap",
    "LockedJointChecker",
    "LockedJoints",
    "MechanicalWork",
    "MetricLength",
    "MotionBound",
    "OccupancyGrid",
    "OptimizationObjective",
    "PRMOptions",
    "PRMStarOptions",
    "PathCertificate",
    "PathLength",
    "PlannerResult",
    "PlannerStatus",
    "Polygon",
    "PolygonWorld",
    "PotentialField",
    "PotentialFieldOptions",
    "PotentialFieldResult",
    "PotentialStatus",
    "RRTConnectOptions",
    "RRTOptions",
    "RRTStarOptions",
    "RRTStatus",
    "Roadmap",
    "SearchStatus",
    "ShortcutOptions",
    "ShortcutResult",
    "SmoothingOptions",
    "SmoothingResult",
    "Tree",
    "WavefrontResult",
    "WeightedSum",
    "angle_distance",
    "astar",
    "bisection_order",
    "bit_star",
    "bug1",
    "bug2",
    "build_lazy_prm",
    "build_prm",
    "certify_path",
    "check_roadmap_world",
    "dijkstra",
    "dubins_distance",
    "dubins_paths",
    "dubins_shortest",
    "gradient_descent",
    "grid_search",
    "grow_control_tree",
    "interpolate",
    "kinodynamic_rrt",
    "lazy_prm",
    "lazy_prm_query",
    "lazy_prm_star",
    "load_moveit_request",
    "load_moveit_scene",
    "motion_bound",
    "motion_bounds",
    "motionbenchmaker_dir",
    "motionbenchmaker_panda",
    "motionbenchmaker_problems",
    "parking_lot",
    "path_length",
    "planner_limits",
    "prm",
    "prm_query",
    "prm_star",
    "reeds_shepp_distance",
    "reeds_shepp_paths",
    "reeds_shepp_shortest",
    "rrt",
    "rrt_connect",
    "rrt_star",
    "sample_free",
    "se2_distance",
    "shortcut_path",
    "smooth_bspline",
    "wavefront",
    "wavefront_path",
    "wrap_angle",
]
