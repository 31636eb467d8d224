"""The sample clip: OpenCV's `vtest.avi` (768x576, 10 fps, pedestrians, static camera), taken from
Debian/Ubuntu's `opencv-doc` package without installing it (no rclpy).

    fetch_sample      download and unpack the .deb with apt-get/dpkg-deb, verify the checksum,
                      cache the clip in ${XDG_CACHE_HOME:-~/.cache}/tracker_suite/vtest.avi

`sample_or_synthetic()` is what the demo uses: the clip when it can be had, otherwise a generated
synthetic scene, with a message saying which and how to pass any video instead.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

CLIP_NAME = "vtest.avi"
PACKAGE = "opencv-doc"
MEMBER_SUFFIX = "/examples/data/vtest.avi"
# SHA-256 of vtest.avi as shipped in opencv-doc (Debian 12, 4.6.0+dfsg-12; the file is OpenCV's
# samples/data/vtest.avi, unchanged across releases).
KNOWN_SHA256 = {"45cddc9490be69345cbdab64ca583be65987e864ca408038e648db99e10516cf"}


class SampleUnavailableError(RuntimeError):
    """The clip cannot be fetched here; the message says why."""


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "tracker_suite"


def sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fetch_sample(directory: Path | None = None) -> Path:
    """The verified clip, downloading it first if it is not cached."""
    target = (directory or cache_dir()) / CLIP_NAME
    if target.exists() and sha256(target) in KNOWN_SHA256:
        return target
    if shutil.which("apt-get") is None or shutil.which("dpkg-deb") is None:
        raise SampleUnavailableError(
            "no apt-get/dpkg-deb on this machine to fetch the opencv-doc package"
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as temp:
        deb = _download_deb(Path(temp))
        extracted = Path(temp) / CLIP_NAME
        _extract_clip(deb, extracted)
        digest = sha256(extracted)
        if digest not in KNOWN_SHA256:
            raise SampleUnavailableError(
                f"{CLIP_NAME} from {deb.name} has an unknown checksum {digest}"
            )
        shutil.move(str(extracted), target)
    return target


def _download_deb(directory: Path) -> Path:
    def download() -> subprocess.CompletedProcess:
        return subprocess.run(
            ["apt-get", "download", PACKAGE],
            cwd=directory,
            capture_output=True,
            text=True,
            timeout=600,
        )

    result = download()
    if result.returncode != 0 and os.geteuid() == 0:
        subprocess.run(
            ["apt-get", "update", "-qq"], capture_output=True, timeout=600
        )  # stale lists
        result = download()
    debs = list(directory.glob(f"{PACKAGE}_*.deb"))
    if result.returncode != 0 or not debs:
        reason = (result.stderr or result.stdout).strip().splitlines()[-1:] or ["no output"]
        raise SampleUnavailableError(f"'apt-get download {PACKAGE}' failed: {reason[0]}")
    return debs[0]


def _extract_clip(deb: Path, target: Path) -> None:
    with (
        subprocess.Popen(
            ["dpkg-deb", "--fsys-tarfile", str(deb)],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,  # it complains when we stop reading after the clip
        ) as unpack,
        tarfile.open(fileobj=unpack.stdout, mode="r|*") as archive,
    ):
        for member in archive:
            wanted = member.isfile() and member.name.endswith(MEMBER_SUFFIX)
            source = archive.extractfile(member) if wanted else None
            if source is not None:  # a regular file of that name
                with source, target.open("wb") as out:
                    shutil.copyfileobj(source, out)
                break
    if not target.exists():
        raise SampleUnavailableError(f"{deb.name} does not contain {CLIP_NAME}")


def synthetic_fallback(directory: Path | None = None) -> Path:
    """A generated surveillance-like scene (people-sized objects walking in and out), cached."""
    from tracker_ptz_sim.simulation.scene_files import META_NAME, scene_video, write_scene
    from tracker_ptz_sim.simulation.scenes import SceneConfig, generate_scene

    root = (directory or cache_dir()) / "synthetic_demo_scene"
    if not (root / META_NAME).exists():
        config = SceneConfig(
            width=640,
            height=480,
            num_frames=300,
            fps=10.0,
            num_objects=4,
            object_size_range=(30, 70),
            speed_range=(20.0, 45.0),
            turns=1,
            stops=1,
            entries_exits=True,
            noise_sigma=2.0,
            illumination_drift=0.05,
            seed=7,
        )
        write_scene(generate_scene(config), root)
    return scene_video(root)


def sample_or_synthetic() -> tuple[Path, str]:
    """The input for the demo and a line telling the user what it is."""
    try:
        path = fetch_sample()
        return path, f"Replaying the sample clip {path} (768x576, 10 fps, pedestrians)."
    except (SampleUnavailableError, OSError, subprocess.SubprocessError) as error:
        path = synthetic_fallback()
        return path, (
            f"The sample clip is not available here ({error}); replaying a generated synthetic "
            f"scene instead: {path}. Pass any video with: make demo VIDEO=path/to/video.mp4"
        )


def main() -> int:
    try:
        path = fetch_sample()
    except SampleUnavailableError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    print(path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
