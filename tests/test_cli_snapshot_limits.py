"""``taskspace snapshot --q`` refuses a configuration outside the joint limits (status 2).

It rendered ``--q 1e300,...`` (a robot far outside Panda's limits) without a word. Panda's
joint 1 is limited to [-2.8973, 2.8973] rad (franka_description).
"""

from __future__ import annotations

from taskspace.cli import main


def test_snapshot_refuses_q_outside_the_limits(capsys, tmp_path) -> None:
    q = "1e300,0,0,-1.5,0,1.5,0"
    assert main(["snapshot", "panda", "--q", q, "--png", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err
    assert "outside the joint limits" in err and "panda_joint1" in err
    assert not (tmp_path / "x.png").exists()
