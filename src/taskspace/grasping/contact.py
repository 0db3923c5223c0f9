"""Contact models of a grasp: frictionless point, Coulomb point, soft finger.

A contact touches the object at ``position`` with the inward unit ``normal`` (the direction
in which the finger pushes). Its frame ``R = [t1 t2 n]`` has the normal as third axis. The
force a contact can apply lies in a cone:

* frictionless point: ``f = f_n n`` with ``f_n >= 0`` (one wrench direction);
* point with Coulomb friction: ``|f_t| <= mu f_n``, linearized by ``m`` edges
  ``d_j = n + mu (cos(2 pi j/m) t1 + sin(2 pi j/m) t2)`` (an inscribed pyramid), or the exact
  second-order cone;
* soft finger: friction plus a torsional moment ``|tau_n| <= gamma f_n`` about the normal,
  linearized by the ``m`` friction edges and the two pure-torsion edges ``(n, +-gamma n)``.

Each edge has a unit normal component, so a set of coefficients with ``sum <= 1`` bounds the
normal force by one (the L1 convention of Ferrari and Canny).

Thread safety: the classes of this module are immutable values (frozen dataclasses, enums); its
functions build their workspaces (Pinocchio and coal data, QP solvers, arrays) per call and may
run from several threads. A numpy generator passed as ``rng`` is shared state: numpy serializes
its draws, but for reproducible results give each thread its own.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from taskspace._validation import as_float_array, as_vector, check_positive
from taskspace.errors import InvalidInputError, ShapeError

#: The most edges a linearized friction cone may have (``force_closure(exact_cone=True)``
#: stops doubling at 1024; more only costs memory and LP time).
MAX_EDGES = 4096

FloatArray = npt.NDArray[np.float64]


class ContactType(enum.Enum):
    """How a finger touches the object."""

    FRICTIONLESS = "frictionless"
    POINT_FRICTION = "point_friction"
    SOFT_FINGER = "soft_finger"


@dataclass(frozen=True)
class GraspContact:
    """One contact of a grasp.

    Attributes:
        position: contact point in the object's frame [m], shape (3,).
        normal: inward unit normal (the direction the finger pushes), shape (3,).
        type: the contact model.
        mu: Coulomb friction coefficient (ignored when frictionless).
        torsion: soft-finger torsional coefficient ``gamma`` [m] (``|tau_n| <= gamma f_n``).
        frame: optional name of the finger frame that touches (for the hand Jacobian).
    """

    position: FloatArray
    normal: FloatArray
    type: ContactType = ContactType.POINT_FRICTION
    mu: float = 0.5
    torsion: float = 0.0
    frame: str | None = field(default=None)

    def __post_init__(self) -> None:
        p = as_float_array(self.position, "position").reshape(-1)
        n = as_float_array(self.normal, "normal").reshape(-1)
        if p.shape != (3,):
            raise ShapeError("position", (3,), p.shape)
        if n.shape != (3,):
            raise ShapeError("normal", (3,), n.shape)
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
            raise InvalidInputError("contact position and normal must be finite")
        norm = float(np.linalg.norm(n))
        if norm < 1e-12:
            raise InvalidInputError("contact normal must not be zero")
        if not isinstance(self.type, ContactType):
            raise InvalidInputError(
                f"type must be a ContactType ({', '.join(t.name for t in ContactType)}), "
                f"got {self.type!r}"
            )
        for name in ("mu", "torsion"):
            object.__setattr__(self, name, nonnegative(getattr(self, name), name))
        if self.frame is not None and not isinstance(self.frame, str):
            raise InvalidInputError(
                f"frame must be the name (str) of the finger frame or None, got {self.frame!r}"
            )
        object.__setattr__(self, "position", p.copy())
        object.__setattr__(self, "normal", n / norm)

    @property
    def rotation(self) -> FloatArray:
        """Contact frame ``[t1 t2 n]`` (columns), a rotation matrix."""
        return contact_frame(self.normal)

    def wrench_dim(self) -> int:
        """Number of force components the contact transmits (1, 3 or 4)."""
        return {ContactType.FRICTIONLESS: 1, ContactType.POINT_FRICTION: 3}.get(self.type, 4)


def nonnegative(value: object, name: str) -> float:
    """``value`` as a float if it is a finite real number ``>= 0`` (booleans refused)."""
    if isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be a finite number >= 0, got {value!r}")
    return check_positive(value, name, strict=False)


def check_edges(edges: object) -> int:
    """``edges`` as an int if it is an integer in ``[3, MAX_EDGES]``."""
    if (
        isinstance(edges, (bool, np.bool_))
        or not isinstance(edges, (int, np.integer))
        or not 3 <= edges <= MAX_EDGES
    ):
        raise InvalidInputError(f"edges must be an integer in [3, {MAX_EDGES}], got {edges!r}")
    return int(edges)


def check_contacts(contacts: object) -> list[GraspContact]:
    """``contacts`` as a non-empty list of :class:`GraspContact`."""
    if isinstance(contacts, GraspContact):
        contacts = [contacts]
    try:
        out = list(contacts)  # type: ignore[call-overload]
    except TypeError:
        raise InvalidInputError(
            f"contacts must be a list of GraspContact, got {type(contacts).__name__}"
        ) from None
    if not out:
        raise InvalidInputError("a grasp needs at least one contact")
    for i, c in enumerate(out):
        if not isinstance(c, GraspContact):
            raise InvalidInputError(
                f"contacts[{i}] must be a GraspContact (position, normal, type, mu...), "
                f"got {type(c).__name__}"
            )
    return out


def check_center(center: object) -> FloatArray:
    """The moment reference point as a finite (3,) vector (the origin for ``None``)."""
    return np.zeros(3) if center is None else as_vector(center, 3, "center")


def contact_frame(normal: FloatArray) -> FloatArray:
    """A rotation ``[t1 t2 n]`` whose third column is the unit ``normal`` (deterministic)."""
    v = as_vector(normal, 3, "normal")
    norm = float(np.linalg.norm(v))
    if not norm > 1e-12:
        raise InvalidInputError("normal must not be zero")
    n = v / norm
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    t1 = np.cross(helper, n)
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    return np.column_stack([t1, t2, n])


def _skew(v: FloatArray) -> FloatArray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def contact_edges(contact: GraspContact, edges: int = 8, mu: float | None = None) -> FloatArray:
    """Generators of the contact's (linearized) cone as 6-D wrench directions ``(f, tau_n n)``.

    Returns an array ``(k, 4)``: columns force in the world (3) and torsional moment about
    the normal (1). ``mu`` overrides the contact's coefficient (used to build an outer cone).
    """
    edges = check_edges(edges)
    if not isinstance(contact, GraspContact):
        raise InvalidInputError(f"contact must be a GraspContact, got {type(contact).__name__}")
    R = contact.rotation
    n = R[:, 2]
    if contact.type is ContactType.FRICTIONLESS:
        return np.hstack([n, 0.0])[None, :]
    m = contact.mu if mu is None else nonnegative(mu, "mu")
    theta = 2.0 * np.pi * np.arange(edges) / edges
    forces = n[None, :] + m * (np.cos(theta)[:, None] * R[:, 0] + np.sin(theta)[:, None] * R[:, 1])
    out = np.hstack([forces, np.zeros((edges, 1))])
    if contact.type is ContactType.SOFT_FINGER and contact.torsion > 0:
        torsion = np.array([np.hstack([n, contact.torsion]), np.hstack([n, -contact.torsion])])
        out = np.vstack([out, torsion])
    return out


def primitive_wrenches(
    contacts: list[GraspContact],
    *,
    edges: int = 8,
    center: FloatArray | None = None,
    torque_scale: float | None = None,
    mu_scale: float = 1.0,
) -> tuple[FloatArray, list[int]]:
    """The wrenches ``w = (f, ((p - c) x f + tau_n n) / rho)`` of every cone edge.

    Args:
        contacts: the grasp's contacts.
        edges: edges of each linearized friction cone.
        center: the point about which moments are taken [m] (default: the origin).
        torque_scale: ``rho`` [m], dividing moments so that forces and moments are commensurate
            (default: the largest distance of a contact from the center, as Ferrari and Canny).
        mu_scale: multiplies every friction coefficient (``1 / cos(pi / edges)`` gives the
            circumscribed pyramid, an outer approximation of the exact cone).

    Returns:
        ``(W, owner)``: ``W`` of shape ``(K, 6)``, one primitive wrench a row, and the index of
        the contact each row belongs to.
    """
    contacts = check_contacts(contacts)
    edges = check_edges(edges)
    mu_scale = nonnegative(mu_scale, "mu_scale")
    c = check_center(center)
    if torque_scale is None:
        rho = grasp_radius(contacts, c)
    elif isinstance(torque_scale, (bool, np.bool_)):
        raise InvalidInputError(f"torque_scale must be a length [m] > 0, got {torque_scale!r}")
    else:
        rho = check_positive(torque_scale, "torque_scale [m]")
    rows, owner = [], []
    for i, contact in enumerate(contacts):
        gens = contact_edges(contact, edges, mu=contact.mu * mu_scale)
        r = (contact.position - c) / rho  # scaled first: r x f / rho could overflow
        for g in gens:
            f, tau_n = g[:3], g[3]
            rows.append(np.hstack([f, np.cross(r, f) + (tau_n / rho) * contact.normal]))
            owner.append(i)
    return np.array(rows), owner


def grasp_radius(contacts: list[GraspContact], center: FloatArray | None = None) -> float:
    """The largest distance of a contact from ``center`` [m] (1 when every contact is on it)."""
    contacts = check_contacts(contacts)
    c = check_center(center)
    r = max(float(np.hypot.reduce(k.position - c)) for k in contacts)  # no overflow at 1e154
    return r if r > 1e-12 else 1.0
