import os
import stat

import pytest

from slam.atomic import replaced_atomically, write_json_atomic, write_text_atomic


@pytest.fixture
def umask():
    """Set the process's umask for one test, and put the old one back."""
    old = os.umask(0o022)
    yield os.umask
    os.umask(old)


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_results_get_the_mode_of_a_new_file_under_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    write_text_atomic(tmp_path / "a.txt", "a\n")
    write_json_atomic(tmp_path / "m.json", {"a": 1})
    with replaced_atomically(tmp_path / "v.mp4") as tmp:
        tmp.write_bytes(b"x")
    for name in ("a.txt", "m.json", "v.mp4"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == mode, name


def test_a_failed_write_leaves_the_old_file_and_no_temporary(tmp_path):
    write_text_atomic(tmp_path / "a.txt", "old\n")
    with pytest.raises(RuntimeError):
        with replaced_atomically(tmp_path / "a.txt") as tmp:
            tmp.write_text("half")
            raise RuntimeError
    assert (tmp_path / "a.txt").read_text() == "old\n" and os.listdir(tmp_path) == ["a.txt"]
