"""The benchmark renders each scene once and reuses it only while config, background and
generator are the same."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import pytest

from tracker_ptz_sim.bringup import benchmark
from tracker_ptz_sim.simulation import street
from tracker_ptz_sim.simulation.scene_files import load_scene

TINY = street.StreetConfig(
    width=96, height=72, num_frames=2, person_height_far=20.0, person_height_near=40.0, walkers=1
)


def test_a_scene_is_rendered_once_per_config_and_generator(tmp_path, monkeypatch, capsys):
    first = benchmark.prepare_scene("tiny", TINY, None, tmp_path)
    again = benchmark.prepare_scene("tiny", TINY, None, tmp_path)
    assert again == first
    assert capsys.readouterr().out.count("rendering") == 1
    other = benchmark.prepare_scene("tiny", replace(TINY, seed=1), None, tmp_path)
    assert other != first
    changed = tmp_path / "street.py"  # the generator's source, edited
    changed.write_bytes(Path(street.__file__).read_bytes() + b"\n# edited\n")
    monkeypatch.setattr(street, "__file__", str(changed))
    assert benchmark.prepare_scene("tiny", TINY, None, tmp_path) != first


def test_a_scene_appears_whole_or_not_at_all(tmp_path, monkeypatch):
    """Rendered into a directory of the process's own and renamed into place: a reader (another
    benchmark sharing the cache) never sees half a video; a directory an interrupted write left
    without its metadata is replaced; a scene another process put in place first is kept."""
    stale = tmp_path / "leftover"
    stale.mkdir()
    (stale / "scene.mp4").write_bytes(b"half a video")
    scene = street.generate_street(TINY, None)
    benchmark._write_whole(scene, stale)
    assert (stale / benchmark.META_NAME).exists()
    assert len(load_scene(stale).frames) == TINY.num_frames
    placed = benchmark.prepare_scene("tiny", TINY, None, tmp_path)
    before = sorted(p.name for p in placed.iterdir())
    benchmark._write_whole(scene, placed)  # the same scene, finished by someone else first
    assert sorted(p.name for p in placed.iterdir()) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["leftover", placed.name])

    # a rename that fails for any other reason is an error, not a scene that is not there
    def refuse(self, target):
        raise PermissionError(f"cannot rename {self} to {target}")

    monkeypatch.setattr(Path, "rename", refuse)
    with pytest.raises(PermissionError):
        benchmark._write_whole(scene, tmp_path / "elsewhere")
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["leftover", placed.name])
