"""The benchmark renders each scene once and reuses it only while config, background and
generator are the same."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from tracker_ptz_sim.bringup import benchmark
from tracker_ptz_sim.simulation import street

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
