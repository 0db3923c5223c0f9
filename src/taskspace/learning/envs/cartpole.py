"""Gymnasium cart-pole on the registry's ``cartpole`` robot (Pinocchio ABA dynamics).

The classic balancing task of Barto, Sutton and Anderson as in Gymnasium's ``CartPole-v1``:
state ``(x, theta, x', theta')`` of the URDF (``theta = 0`` upright; cart 1 kg, pole 0.1 kg
point mass at 0.5 m), two actions pushing the cart with ``-F`` or ``+F`` [N], reward 1 per
step, termination when ``|theta| > 12 deg`` or ``|x| > 2.4 m``. Observation
``[x, x', theta, theta']`` (Gymnasium's order).

:class:`CartPoleVectorEnv` steps N copies at once with the closed-form equations of motion
of the same point-mass cart-pole (:func:`taskspace.optimal_control.cartpole_acceleration`,
checked against ABA in the tests), without a Python loop over the copies.

:class:`CartPoleEnv` steps Pinocchio's ABA in closed form (:class:`CartPoleDynamics`: the
Lagrangian of a cart on a prismatic joint carrying a pole on a revolute joint, with the
coefficients read from the model by CRBA and generalized gravity and checked against
``pin.aba`` at random states when the environment is built); the substeps run on Python
floats. A model that fails the check is stepped with ``pin.aba``.

Thread safety: an environment (single or batched) is a simulation state and is not thread-safe:
one environment per thread. Shared use is detected: ``reset``/``step`` raise
:class:`~taskspace.errors.ConcurrentUseError` while another thread is inside one of them (see
:mod:`taskspace.learning.envs.robot_env`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pinocchio as pin
from gymnasium import spaces

from taskspace.errors import InvalidInputError
from taskspace.learning.envs.robot_env import (
    RobotEnv,
    RobotVectorEnv,
    action_array,
    one_thread_at_a_time,
    snap_roundoff,
)
from taskspace.model.versioning import ModelFollower
from taskspace.optimal_control.problems import cartpole_acceleration

THETA_LIMIT = 12 * 2 * np.pi / 360
X_LIMIT = 2.4


class CartPoleDynamics:
    """Pinocchio's ABA of a cart-pole (prismatic cart ``x``, revolute pole ``theta``), closed form.

    Kinetic energy ``T = 1/2 m_x x'^2 + m_xt(theta) x' theta' + 1/2 m_t theta'^2`` with
    ``m_xt = b_c cos(theta) + b_s sin(theta)``; Lagrange's equations give
    ``M(theta) [x'', theta''] = tau - [m_xt'(theta) theta'^2 + g_x, g(theta)]`` with
    ``m_xt' = -b_c sin + b_s cos`` and ``g(theta) = g_s sin + g_c cos + g_0``.
    :meth:`from_model` reads the coefficients from the model and returns ``None`` unless
    ``pin.aba`` agrees.

    Attributes:
        mass: ``(m_x, m_t)``; coupling: ``(b_c, b_s)``; gravity: ``(g_x, g_s, g_c, g_0)``.
    """

    def __init__(
        self,
        mass: tuple[float, float],
        coupling: tuple[float, float],
        gravity: tuple[float, ...],
    ) -> None:
        self.mass = (float(mass[0]), float(mass[1]))
        self.coupling = (float(coupling[0]), float(coupling[1]))
        g = [float(x) for x in gravity]
        self.gravity = (g[0], g[1], g[2], g[3])

    @classmethod
    def from_model(cls, model: Any, data: Any, rtol: float = 1e-10) -> CartPoleDynamics | None:
        """Read the coefficients from the model; ``None`` unless ABA agrees to ``rtol``."""
        if model.nq != 2 or model.nv != 2:
            return None
        m0 = pin.crba(model, data, np.zeros(2))
        m90 = pin.crba(model, data, np.array([0.0, 0.5 * math.pi]))
        g0, g90, g180 = (
            pin.computeGeneralizedGravity(model, data, np.array([0.0, th])).copy()
            for th in (0.0, 0.5 * math.pi, math.pi)
        )
        offset = 0.5 * (g0[1] + g180[1])
        coupling = snap_roundoff((m0[0, 1], m90[0, 1]))
        gravity = snap_roundoff((g0[0], g90[1] - offset, 0.5 * (g0[1] - g180[1]), offset))
        dyn = cls((m0[0, 0], m0[1, 1]), (coupling[0], coupling[1]), gravity)
        rng = np.random.default_rng(0)
        for _ in range(8):
            q, v, tau = rng.uniform(-3.0, 3.0, (3, 2))
            ref = pin.aba(model, data, q, v, tau)
            ours = np.array(dyn.acceleration(*q, *v, *tau))
            if not np.all(np.abs(ours - ref) <= rtol * (1.0 + np.abs(ref))):
                return None
        return dyn

    def acceleration(
        self, x: float, theta: float, xd: float, thetad: float, f_x: float, f_theta: float
    ) -> tuple[float, float]:
        """``(x'', theta'')`` under the generalized forces ``(f_x, f_theta)``."""
        del x  # the dynamics do not depend on the cart position
        mx, mt = self.mass
        bc, bs = self.coupling
        gx, gs, gc, g0 = self.gravity
        s, c = math.sin(theta), math.cos(theta)
        mxt = bc * c + bs * s
        r1 = f_x - (bs * c - bc * s) * thetad * thetad - gx
        r2 = f_theta - gs * s - gc * c - g0
        inv_det = 1.0 / (mx * mt - mxt * mxt)
        return (mt * r1 - mxt * r2) * inv_det, (mx * r2 - mxt * r1) * inv_det

    def integrate(
        self, q: list[float], v: list[float], force: float, h: float, substeps: int
    ) -> tuple[list[float], list[float]]:
        """``substeps`` semi-implicit Euler steps of ``h`` [s] pushing the cart with ``force``."""
        mx, mt = self.mass
        bc, bs = self.coupling
        gx, gs, gc, g0 = self.gravity
        sin, cos = math.sin, math.cos
        x, th = q
        xd, thd = v
        for _ in range(substeps):
            s, c = sin(th), cos(th)
            mxt = bc * c + bs * s
            r1 = force - (bs * c - bc * s) * thd * thd - gx
            r2 = -gs * s - gc * c - g0
            inv_det = 1.0 / (mx * mt - mxt * mxt)
            xd = xd + h * ((mt * r1 - mxt * r2) * inv_det)
            thd = thd + h * ((mx * r2 - mxt * r1) * inv_det)
            x = x + h * xd
            th = th + h * thd
        return [x, th], [xd, thd]


def _spaces() -> tuple[spaces.Discrete, spaces.Box]:
    high = np.array([2 * X_LIMIT, np.inf, 2 * THETA_LIMIT, np.inf], dtype=np.float32)
    return spaces.Discrete(2), spaces.Box(-high, high, dtype=np.float32)


class CartPoleEnv(RobotEnv):
    """Cart-pole balancing; registered as ``taskspace/CartPole-v0`` (500 steps).

    Args:
        force: push magnitude [N]; dt: control period [s]; substeps: ABA steps per period.
        render_mode: ``None``, ``"rgb_array"`` (a 400 x 400 x 3 image) or ``"human"``.
    """

    metadata = {**RobotEnv.metadata, "render_fps": 50}  # noqa: RUF012

    def __init__(
        self,
        force: float = 10.0,
        dt: float = 0.02,
        substeps: int = 2,
        render_mode: str | None = None,
    ) -> None:
        super().__init__("cartpole", dt, substeps, render_mode)
        self.force = float(force)
        self.action_space, self.observation_space = _spaces()
        self.q = np.zeros(2)
        self.v = np.zeros(2)
        self.dynamics: CartPoleDynamics | None = None
        """Closed-form ABA of the model (``None``: stepped with ``pin.aba``); derived again
        after ``robot.edit_model`` (the robot's version)."""
        self._dynamics_follower = ModelFollower(self.robot, "CartPoleEnv", self._derive_dynamics)

    def _derive_dynamics(self) -> None:
        self.dynamics = CartPoleDynamics.from_model(self._model, self.data)

    def _obs(self) -> np.ndarray:
        return np.array([self.q[0], self.v[0], self.q[1], self.v[1]], dtype=np.float32)

    @one_thread_at_a_time
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Every state component uniform in ``[-0.05, 0.05]``."""
        super().reset(seed=seed)
        s = self.np_random.uniform(-0.05, 0.05, 4)
        self.q = s[:2].copy()
        self.v = s[2:].copy()
        self._after_step()
        return self._obs(), {}

    @one_thread_at_a_time
    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        """Push for ``dt`` (ABA + semi-implicit Euler substeps)."""
        kind = type(action)
        if kind is int or kind is np.int64:
            valid = action == 0 or action == 1
        else:
            valid = self.action_space.contains(action)
        if not valid:
            raise InvalidInputError(f"action must be 0 or 1, got {action!r}")
        force = self.force if int(action) == 1 else -self.force
        self._dynamics_follower.sync()  # one comparison unless the robot was edited
        if self.dynamics is not None:
            q, v = self.dynamics.integrate(
                self.q.tolist(), self.v.tolist(), force, self.dt / self.substeps, self.substeps
            )
        else:
            qa, va = self._integrate(self.q, self.v, np.array([force, 0.0]))
            q, v = qa.tolist(), va.tolist()
        self.q = np.array(q)
        self.v = np.array(v)
        terminated = abs(q[0]) > X_LIMIT or abs(q[1]) > THETA_LIMIT
        if self.render_mode == "human":
            self.render()
        return np.array([q[0], v[0], q[1], v[1]], dtype=np.float32), 1.0, terminated, False, {}

    def _draw(self, ax: Any) -> None:
        """Track, cart and pole (0.5 m drawn as 1 m, as Gymnasium's picture)."""
        x, th = float(self.q[0]), float(self.q[1])
        ax.set_xlim(-X_LIMIT - 0.3, X_LIMIT + 0.3)
        ax.set_ylim(-0.6, 1.6)
        ax.axis("off")
        ax.plot([-X_LIMIT, X_LIMIT], [0.0, 0.0], color="0.3", lw=1)
        ax.add_patch(_rectangle((x - 0.25, -0.075), 0.5, 0.15, color="#34495e"))
        tip = (x + np.sin(th), np.cos(th))
        ax.plot([x, tip[0]], [0.0, tip[1]], color="#c0392b", lw=6, solid_capstyle="round")


def _rectangle(xy: tuple[float, float], width: float, height: float, **kw: Any) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle(xy, width, height, **kw)


GYMNASIUM_GRAVITY = 9.8
"""Gravity of Gymnasium's ``CartPole-v1`` [m/s^2] (ours: standard gravity 9.80665)."""


class CartPoleVectorEnv(RobotVectorEnv):
    """N cart-poles stepped together (numpy, no loop over copies), auto-reset on termination.

    Same dynamics, rewards and termination as :class:`CartPoleEnv`; truncation after
    ``max_episode_steps``. Registered as ``taskspace/CartPole-v0``'s vector entry point:
    ``gymnasium.make_vec("taskspace/CartPole-v0", num_envs=N,
    vectorization_mode="vector_entry_point")``.

    Args:
        num_envs: number of copies N.
        force: push magnitude [N]; dt: control period [s].
        substeps: integration steps per period (default: 2 for ``model="urdf"``, the same
            as :class:`CartPoleEnv`; 1 for ``model="gymnasium"``, as ``CartPole-v1``).
        model: ``"urdf"`` (default): the registry's cart-pole (point-mass pole, standard
            gravity), semi-implicit Euler with ``dt / substeps``, as :class:`CartPoleEnv`.
            ``"gymnasium"``: Gymnasium's ``CartPole-v1`` dynamics, the same equations in the
            same order (a uniform pole of half-length 0.5 m, inertia ``4/3 m l^2`` about
            the pivot, gravity 9.8, explicit Euler: positions advance with the old
            velocities); with ``substeps = 1`` and ``dt = 0.02`` a step equals
            ``CartPole-v1``'s to the last bit from the same state.
        max_episode_steps: truncation; render_mode: as :class:`CartPoleEnv`.
    """

    MODELS = ("urdf", "gymnasium")

    def __init__(
        self,
        num_envs: int = 1,
        *,
        force: float = 10.0,
        dt: float = 0.02,
        substeps: int | None = None,
        model: str = "urdf",
        max_episode_steps: int = 500,
        render_mode: str | None = None,
    ) -> None:
        if model not in self.MODELS:
            raise InvalidInputError(f"unknown cart-pole model {model!r}; valid: {self.MODELS}")
        if substeps is None:
            substeps = 1 if model == "gymnasium" else 2
        super().__init__(num_envs, dt, substeps, max_episode_steps, render_mode)
        self.model = model
        self.force = float(force)
        self._set_spaces(*_spaces())
        self.q = np.zeros((self.num_envs, 2))
        self.v = np.zeros((self.num_envs, 2))

    def _obs(self) -> np.ndarray:
        return np.stack([self.q[:, 0], self.v[:, 0], self.q[:, 1], self.v[:, 1]], axis=1).astype(
            np.float32
        )

    def _reset_copies(self, mask: np.ndarray) -> None:
        """States uniform in ``[-0.05, 0.05]``."""
        s = self.np_random.uniform(-0.05, 0.05, (int(mask.sum()), 4))
        if np.all(mask):
            self.q, self.v = s[:, :2].copy(), s[:, 2:].copy()
        else:
            self.q[mask], self.v[mask] = s[:, :2], s[:, 2:]

    @one_thread_at_a_time
    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every copy; copies that ended on the previous step are reset instead."""
        act = action_array(actions, (self.num_envs,), "actions")
        if not np.all((act == 0) | (act == 1)):
            raise InvalidInputError("actions must be 0 or 1")
        F = np.where(act == 1, self.force, -self.force)
        h = self.dt / self.substeps
        if self.model == "gymnasium":
            self._gymnasium_substeps(F, h)
        else:
            for _ in range(self.substeps):
                a = cartpole_acceleration(self.q, self.v, F)
                self.v = self.v + h * a
                self.q = self.q + h * self.v
        self.steps += 1
        terminated = (np.abs(self.q[:, 0]) > X_LIMIT) | (np.abs(self.q[:, 1]) > THETA_LIMIT)
        truncated = self.steps >= self.max_episode_steps
        reward = np.ones(self.num_envs)
        self._autoreset(reward, terminated, truncated)
        return self._obs(), reward, terminated, truncated, {}

    def _gymnasium_substeps(self, F: np.ndarray, h: float) -> None:
        """Gymnasium's ``CartPole-v1`` equations (Florian 2007), explicit Euler, same order."""
        masspole, masscart, length = 0.1, 1.0, 0.5
        total_mass = masspole + masscart
        polemass_length = masspole * length
        x, theta = self.q[:, 0], self.q[:, 1]
        x_dot, theta_dot = self.v[:, 0], self.v[:, 1]
        for _ in range(self.substeps):
            costheta = np.cos(theta)
            sintheta = np.sin(theta)
            temp = (F + polemass_length * np.square(theta_dot) * sintheta) / total_mass
            thetaacc = (GYMNASIUM_GRAVITY * sintheta - costheta * temp) / (
                length * (4.0 / 3.0 - masspole * np.square(costheta) / total_mass)
            )
            xacc = temp - polemass_length * thetaacc * costheta / total_mass
            x = x + h * x_dot
            x_dot = x_dot + h * xacc
            theta = theta + h * theta_dot
            theta_dot = theta_dot + h * thetaacc
        self.q = np.stack([x, theta], axis=1)
        self.v = np.stack([x_dot, theta_dot], axis=1)
