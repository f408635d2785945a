"""The batch manifest's digest of the installed code: a rerun after another build of the
same version redoes its tiles (tests/test_batch.py runs that end to end)."""

from __future__ import annotations

import os

from pcl_rg.batch import _manifest


def test_the_code_digest_follows_every_byte_of_the_code_and_nothing_else(tmp_path):
    digest = _manifest.code_digest.__wrapped__  # uncached: the tree changes below
    package = tmp_path / "package"
    (package / "sub" / "__pycache__").mkdir(parents=True)
    (package / "a.py").write_bytes(b"x = 1\n")
    (package / "sub" / "_core.so").write_bytes(bytes(range(256)))
    (package / "sub" / "__pycache__" / "a.cpython-311.pyc").write_bytes(b"old")
    (package / "notes.md").write_text("prose")
    before = digest(str(package))
    assert digest(str(package)) == before
    # Neither bytecode nor data changes what the package computes.
    (package / "sub" / "__pycache__" / "a.cpython-311.pyc").write_bytes(b"new")
    (package / "notes.md").write_text("other prose")
    assert digest(str(package)) == before
    # One byte of an extension, or of a module, or a module's name does.
    (package / "sub" / "_core.so").write_bytes(bytes(range(255)) + b"\0")
    changed_extension = digest(str(package))
    (package / "a.py").write_bytes(b"x = 2\n")
    changed_module = digest(str(package))
    (package / "a.py").rename(package / "b.py")
    renamed = digest(str(package))
    assert len({before, changed_extension, changed_module, renamed}) == 4
    # The installed package's, cached, is its own tree's.
    assert _manifest.code_digest() == digest(_manifest.PACKAGE_FOLDER)
    assert os.path.isfile(os.path.join(_manifest.PACKAGE_FOLDER, "batch", "_manifest.py"))
