"""rai's KOMO (PyPI ``robotic``) on the path-optimization scene of
benchmarks/suites/path_optimization.py (run in .venv-peers/robotic).

Usage: python robotic_path_optimization.py SPEC.json; prints one JSON line with, per T, the
solve times [s] and the feasibility of the result.

The scene: rai's own Panda (``panda/panda.g``, capsule collision shapes), a sphere obstacle,
acceleration control cost (order 2), final gripper pose equal to the pose at ``q_goal``
(``poseDiff`` equality), every arm/hand collision shape at least ``margin`` away from the
sphere (``distance`` inequalities) and the joint limits, on T slices over one phase.
"""

import json
import sys
import time

import numpy as np


def build(ry, spec, T):
    C = ry.Config()
    C.addFile(ry.raiPath("panda/panda.g"))
    C.addFrame("ball").setShape(ry.ST.sphere, [spec["radius"]]).setPosition(
        spec["center"]
    ).setContact(1)
    C.setJointState(np.array(spec["q_goal"]))
    goal = C.getFrame("gripper").getPose()
    C.addFrame("target").setShape(ry.ST.marker, [0.1]).setPose(goal)
    C.setJointState(np.array(spec["q_start"]))
    komo = ry.KOMO(C, 1.0, T, 2, False)
    komo.addControlObjective([], 2, 1.0)
    komo.addObjective([], ry.FS.jointLimits, [], ry.OT.ineq, [1e1])
    komo.addObjective([1.0], ry.FS.poseDiff, ["gripper", "target"], ry.OT.eq, [1e1])
    for shape in spec["shapes"]:
        komo.addObjective([], ry.FS.distance, [shape, "ball"], ry.OT.ineq, [1e1], [-spec["margin"]])
    return C, komo


def main():
    spec = json.load(open(sys.argv[1]))
    import robotic as ry

    out = {"T": {}}
    for T in spec["horizons"]:
        times, feasible, eq, ineq, evals = [], [], [], [], []
        for _ in range(spec["repeat"]):
            C, komo = build(ry, spec, T)
            solver = ry.NLP_Solver(komo.nlp(), verbose=0)
            t0 = time.perf_counter()
            ret = solver.solve()
            times.append(time.perf_counter() - t0)
            feasible.append(bool(ret.feasible))
            eq.append(float(ret.eq))
            ineq.append(float(ret.ineq))
            evals.append(int(ret.evals))
            # measured distances along the path (feasibility checked here, not trusted)
        path = komo.getPath()
        min_distance = np.inf
        for q in path:
            C.setJointState(q)
            for shape in spec["shapes"]:
                y, _ = C.eval(ry.FS.distance, [shape, "ball"])
                min_distance = min(min_distance, -float(y[0]))
        C.setJointState(path[-1])
        final_error = float(
            np.linalg.norm(C.getFrame("gripper").getPosition() - C.getFrame("target").getPosition())
        )
        out["T"][str(T)] = {
            "times": times,
            "feasible": feasible,
            "eq": eq,
            "ineq": ineq,
            "evals": evals,
            "min_distance": min_distance,
            "final_position_error": final_error,
        }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
