"""Issue 16, the files of one call are all or none (docs/reliability.md, "Outputs: all or
nothing"): a later output that cannot be written raises and leaves none of the call's new
files and no staging folder; special files are written in place."""
import os
import stat

import pytest

import ivdyn

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
UR5 = os.path.join(ROOT, "fixtures", "ur5.urdf")


@pytest.fixture(scope="module")
def ur5():
    return ivdyn.Robot.from_urdf(UR5, base="base_link", tip="tool0")


def test_simulate_later_output_fails_leaves_none(ur5, tmp_path):
    with pytest.raises(FileNotFoundError, match="s.json"):
        ivdyn.simulate(ur5, tmp_path / "x.mcap", duration=2, out_json=tmp_path / "no" / "s.json")
    assert os.listdir(tmp_path) == []


def test_identify_later_output_fails_leaves_none(ur5, tmp_path):
    log = tmp_path / "log.mcap"
    ivdyn.simulate(ur5, log, duration=8, noise=0.05)
    (tmp_path / "taken.mcap").mkdir()  # a folder where the prediction MCAP should go
    with pytest.raises(OSError, match="taken.mcap"):
        ivdyn.identify(ur5, log, out_json=tmp_path / "r.json", out_params=tmp_path / "p.json",
                       out_mcap=tmp_path / "taken.mcap")
    assert sorted(os.listdir(tmp_path)) == ["log.mcap", "taken.mcap"]


def test_out_json_to_dev_null_in_place(ur5, tmp_path):
    ivdyn.simulate(ur5, tmp_path / "x.csv", duration=2, out_json=os.devnull)
    assert stat.S_ISCHR(os.lstat(os.devnull).st_mode)
    assert os.listdir(tmp_path) == ["x.csv"]
