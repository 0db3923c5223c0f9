"""Control: PID on a point mass, computed torque, operational space, LQR and linear theory.

Slides 5:5-5:35 and the control-theory chapter of the lecture notes. The inverse-dynamics
QP (torque limits, contacts) lives in :mod:`taskspace.control.inverse_dynamics_qp`.
"""

from taskspace.control.adaptive import (
    AdaptiveOptions,
    AdaptivePendulumController,
    AdaptiveSimulation,
    ReferenceModel,
    simulate_adaptive_pendulum,
)
from taskspace.control.computed_torque import (
    ComputedTorqueController,
    JointPDController,
    gains_from_wavelength,
    tracking_error,
)
from taskspace.control.controllability import (
    ControllabilityResult,
    controllability,
    controllability_matrix,
    is_controllable,
)
from taskspace.control.finite_horizon import (
    FiniteHorizonLQR,
    solve_riccati_differential,
    solve_riccati_recursion,
)
from taskspace.control.inverse_dynamics_qp import (
    CenterOfPressureTask,
    InverseDynamicsOptions,
    InverseDynamicsQP,
    InverseDynamicsResult,
    InverseDynamicsStatus,
)
from taskspace.control.inverse_dynamics_qp_rollout import ContactRollout, simulate_with_contacts
from taskspace.control.linearization import LinearizedSystem, linearize
from taskspace.control.lqr import LQROptions, LQRResult, LQRStatus, dlqr, lqr
from taskspace.control.lyapunov import (
    LyapunovCertificate,
    lyapunov_check,
    solve_discrete_lyapunov,
    solve_lyapunov,
)
from taskspace.control.observability import (
    KalmanDecomposition,
    ObservabilityResult,
    is_observable,
    kalman_decomposition,
    observability,
    observability_matrix,
)
from taskspace.control.operational_space import (
    OperationalSpaceController,
    OperationalSpaceOptions,
    OperationalSpaceResult,
    OperationalSpaceStatus,
    operational_space_control,
)
from taskspace.control.pid import PIDController, PIDGains, PIDOptions
from taskspace.control.point_mass import (
    DampingRegime,
    PointMassResponse,
    critically_damped_response,
    damping_ratio,
    damping_regime,
    overdamped_response,
    pd_response,
    point_mass_pid_matrix,
    point_mass_robot,
    underdamped_response,
)
from taskspace.control.pole_placement import (
    PolePlacementMethod,
    PolePlacementOptions,
    PolePlacementResult,
    acker,
    observer_gain,
    place,
    place_poles,
)
from taskspace.control.reference import (
    ConstantReference,
    JointReference,
    ReferencePoint,
    SampledReference,
    SinusoidalReference,
)
from taskspace.control.riccati import (
    RiccatiMethod,
    RiccatiOptions,
    RiccatiResult,
    RiccatiStatus,
    care_residual,
    dare_residual,
    solve_continuous_riccati,
    solve_discrete_riccati,
)
from taskspace.control.stability import StabilityResult, is_stable, stability
from taskspace.control.state_feedback import StateFeedbackController

__all__ = [
    "AdaptiveOptions",
    "AdaptivePendulumController",
    "AdaptiveSimulation",
    "CenterOfPressureTask",
    "ComputedTorqueController",
    "ConstantReference",
    "ContactRollout",
    "ControllabilityResult",
    "DampingRegime",
    "FiniteHorizonLQR",
    "InverseDynamicsOptions",
    "InverseDynamicsQP",
    "InverseDynamicsResult",
    "InverseDynamicsStatus",
    "JointPDController",
    "JointReference",
    "KalmanDecomposition",
    "LQROptions",
    "LQRResult",
    "LQRStatus",
    "LinearizedSystem",
    "LyapunovCertificate",
    "ObservabilityResult",
    "OperationalSpaceController",
    "OperationalSpaceOptions",
    "OperationalSpaceResult",
    "OperationalSpaceStatus",
    "PIDController",
    "PIDGains",
    "PIDOptions",
    "PointMassResponse",
    "PolePlacementMethod",
    "PolePlacementOptions",
    "PolePlacementResult",
    "ReferenceModel",
    "ReferencePoint",
    "RiccatiMethod",
    "RiccatiOptions",
    "RiccatiResult",
    "RiccatiStatus",
    "SampledReference",
    "SinusoidalReference",
    "StabilityResult",
    "StateFeedbackController",
    "acker",
    "care_residual",
    "controllability",
    "controllability_matrix",
    "critically_damped_response",
    "damping_ratio",
    "damping_regime",
    "dare_residual",
    "dlqr",
    "gains_from_wavelength",
    "is_controllable",
    "is_observable",
    "is_stable",
    "kalman_decomposition",
    "linearize",
    "lqr",
    "lyapunov_check",
    "observability",
    "observability_matrix",
    "observer_gain",
    "operational_space_control",
    "overdamped_response",
    "pd_response",
    "place",
    "place_poles",
    "point_mass_pid_matrix",
    "point_mass_robot",
    "simulate_adaptive_pendulum",
    "simulate_with_contacts",
    "solve_continuous_riccati",
    "solve_discrete_lyapunov",
    "solve_discrete_riccati",
    "solve_lyapunov",
    "solve_riccati_differential",
    "solve_riccati_recursion",
    "stability",
    "tracking_error",
    "underdamped_response",
]
