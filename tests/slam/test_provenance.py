"""A result names the software it was computed with: the checkout's commit, marked dirty when
tracked files differ from it, and the versions the libraries themselves report."""

import subprocess

import kiss_icp
import numba
import numpy as np
import pytest
import scipy
import sklearn

from slam.provenance import _commit, software


def git(root, *args):
    return subprocess.run(["git", "-C", str(root), "-c", "user.name=t", "-c", "user.email=t@t", *args],
                          capture_output=True, text=True, check=True).stdout.strip()


def test_the_libraries_are_named_at_the_versions_they_report():
    packages = software()["packages"]
    assert packages["numpy"] == np.__version__
    assert packages["scipy"] == scipy.__version__
    assert packages["scikit-learn"] == sklearn.__version__
    assert packages["numba"] == numba.__version__
    assert packages["kiss-icp"] == kiss_icp.__version__
    assert packages["gtsam"]                               # gtsam reports no __version__


def test_a_commit_is_marked_dirty_while_a_tracked_file_differs_from_it(tmp_path):
    assert _commit(tmp_path) is None                       # no checkout: no commit
    git(tmp_path, "init", "-q")
    (tmp_path / "a.py").write_text("x = 1\n")
    git(tmp_path, "add", "a.py")
    git(tmp_path, "commit", "-q", "-m", "a")
    head = git(tmp_path, "rev-parse", "HEAD")
    assert _commit(tmp_path) == head
    (tmp_path / "b.py").write_text("untracked\n")          # a new file is not the code run
    assert _commit(tmp_path) == head
    (tmp_path / "a.py").write_text("x = 2\n")
    assert _commit(tmp_path) == head + "-dirty"


def test_an_installed_copy_inside_another_checkout_names_no_commit(tmp_path):
    # a package installed into a virtual environment within a checkout is not that checkout's code
    git(tmp_path, "init", "-q")
    (tmp_path / "a.py").write_text("x = 1\n")
    git(tmp_path, "add", "a.py")
    git(tmp_path, "commit", "-q", "-m", "a")
    inner = tmp_path / ".venv" / "lib" / "site-packages"
    inner.mkdir(parents=True)
    assert _commit(inner) is None


@pytest.mark.parametrize("key", ["python", "machine"])
def test_the_platform_is_named(key):
    assert software()[key]
