"""Path planning (lecture section 3): bugs, potential fields, grids, graphs, curves, PRMs, RRTs."""
# ruff: noqa: F401

from taskspace.planning.bug import BugOptions, BugResult, BugStatus, bug1, bug2
from taskspace.planning.car import CarModel, ControlSamplingOptions, ControlTree, grow_control_tree
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
from taskspace.planning.kinodynamic_rrt import (
    KinodynamicRRTOptions,
    KinodynamicRRTResult,
    RRTStatus,
    kinodynamic_rrt,
    parking_lot,
)
from taskspace.planning.lazy_prm import LazyRoadmap, build_lazy_prm, lazy_prm, lazy_prm_query
from taskspace.planning.nearest import GrowingNearest
from taskspace.planning.planner_result import PlannerResult, PlannerStatus, Tree
from taskspace.planning.polygon_world import Polygon, PolygonWorld
from taskspace.planning.potential_field import (
    PotentialField,
    PotentialFieldOptions,
    PotentialFieldResult,
    PotentialStatus,
    gradient_descent,
)
from taskspace.planning.prm import PRMOptions, Roadmap, build_prm, prm, prm_query
from taskspace.planning.reeds_shepp import (
    reeds_shepp_distance,
    reeds_shepp_paths,
    reeds_shepp_shortest,
)
from taskspace.planning.rrt import RRTOptions, rrt
from taskspace.planning.rrt_connect import RRTConnectOptions, rrt_connect
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
from taskspace.planning.shortcut import ShortcutOptions, shortcut_path
