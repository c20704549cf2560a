"""Real camera raw files for checking the development pipeline, fetched from a package registry.

A real photo is too large to keep in the repository, and the machines rigsim is built on
reach only package registries.  PyPI keeps test photos inside some packages' source
archives; :data:`SAMPLE_RAWS` names one, with the archive's address and checksums, and
:func:`fetch_sample_raw` downloads the archive once, checks it, and keeps only the photo
in a cache folder (``$RIGSIM_CACHE``, default ``~/.cache/rigsim``).

>>> sorted(SAMPLE_RAWS)
['sony-ilce-7rm3']
"""

from __future__ import annotations

import hashlib
import io
import os
import tarfile
import urllib.request
from dataclasses import dataclass
from pathlib import Path

from rigsim.errors import ConfigError, unknown_name_error
from rigsim.fileio import atomic_write_bytes

__all__ = ["SampleRaw", "SAMPLE_RAWS", "cache_dir", "sample_raw_path", "fetch_sample_raw"]


@dataclass(frozen=True)
class SampleRaw:
    """One real raw photo inside a package archive."""

    name: str
    camera: str
    description: str
    archive_url: str
    archive_sha256: str
    member: str
    sha256: str
    size_bytes: int
    licence: str

    @property
    def filename(self) -> str:
        return Path(self.member).name


SAMPLE_RAWS: dict[str, SampleRaw] = {s.name: s for s in [
    SampleRaw(
        name="sony-ilce-7rm3",
        camera="Sony ILCE-7RM3 (A7R III), E 55-210mm F4.5-6.3 OSS",
        description="Sony compressed ARW, 14-bit, 5216×3464 (RGGB), black 512, white 16383; "
                    "ISO 3200, 1/640 s, f/6.3, 2018-07-11",
        archive_url="https://files.pythonhosted.org/packages/4e/39/"
                    "2053522dae1f00bc69475107424eca6d16932024963b8c361a92474a1651/libraw_cffi-0.19.0.tar.gz",
        archive_sha256="c92b259c0a82a87e5e3636b8ffef84bcc3c0781c595994b09ceb9b87892ea930",
        member="libraw_cffi-0.19.0/libraw_cffi/tests/_DSC2164.ARW",
        sha256="42ec55eef6047c1bfbd1fd05fdcae78993f3513814138eff4cbcf9498c57d4e6",
        size_bytes=18_649_856,
        licence="test fixture of the PyPI package libraw-cffi 0.19.0 (MIT, © 2018 Julian Berman; "
                "https://github.com/Julian/libraw-cffi); no separate licence is stated for the photo",
    ),
]}


def cache_dir() -> Path:
    """Folder for downloaded samples: ``$RIGSIM_CACHE`` or ``~/.cache/rigsim``."""
    from rigsim.fileio import cache_dir as rigsim_cache

    return rigsim_cache()


def _sample(name: str) -> SampleRaw:
    if name not in SAMPLE_RAWS:
        raise unknown_name_error("sample raw file", name, SAMPLE_RAWS, field="sample")
    return SAMPLE_RAWS[name]


def sample_raw_path(name: str) -> Path:
    """Where sample ``name`` is (or will be) kept."""
    s = _sample(name)
    return cache_dir() / "samples" / s.filename


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def fetch_sample_raw(name: str = "sony-ilce-7rm3", *, timeout_s: float = 120.0) -> Path:
    """Path of sample ``name``, downloading and checking it first if it is not cached.

    Raises
    ------
    ConfigError
        If the name is unknown, the archive cannot be downloaded, or a checksum differs.
    """
    s = _sample(name)
    path = sample_raw_path(name)
    if path.is_file() and path.stat().st_size == s.size_bytes:
        return path
    try:
        with urllib.request.urlopen(s.archive_url, timeout=timeout_s) as resp:  # noqa: S310 - fixed https URL
            archive = resp.read()
    except OSError as exc:
        raise ConfigError(f"cannot download the sample raw file's archive ({exc})", file=s.archive_url,
                          field="sample", allowed="a machine that reaches files.pythonhosted.org") from None
    if _sha256(archive) != s.archive_sha256:
        raise ConfigError("the downloaded archive's SHA-256 differs from the recorded one", file=s.archive_url,
                          field="archive_sha256", allowed=s.archive_sha256)
    with tarfile.open(fileobj=io.BytesIO(archive), mode="r:gz") as tar:
        f = tar.extractfile(s.member)
        if f is None:
            raise ConfigError("member not found in the archive", file=s.archive_url, field="member",
                              allowed=s.member)
        data = f.read()
    if _sha256(data) != s.sha256:
        raise ConfigError("the sample's SHA-256 differs from the recorded one", file=s.member, field="sha256",
                          allowed=s.sha256)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, data)
    return path
