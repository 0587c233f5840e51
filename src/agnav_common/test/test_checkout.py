"""The checkout is found from an editable install, from $AGNAV_ROOT, and is the cwd for a plain installed copy."""
from pathlib import Path

from agnav_common.checkout import checkout_root, find_checkout


def test_checkout_is_found_above_a_source_file():
    here = Path(__file__).resolve()
    root = find_checkout(here.parent)
    assert root is not None and (root / "bags").is_dir() and here.is_relative_to(root)


def test_an_installed_copy_uses_agnav_root_or_the_cwd(tmp_path, monkeypatch):
    installed = tmp_path / "install" / "agnav_bringup" / "lib" / "graph_config.py"
    installed.parent.mkdir(parents=True)
    installed.write_text("")
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("AGNAV_ROOT", raising=False)
    assert checkout_root(installed) == tmp_path
    monkeypatch.setenv("AGNAV_ROOT", "/data/agnav")
    assert checkout_root(installed) == Path("/data/agnav")
