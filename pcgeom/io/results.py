"""The results file: :class:`ParamResult`, saved and loaded as one ``.npz``.

A map written by ``pcgeom param`` (or :meth:`ParamResult.save`) holds NumPy arrays and JSON
strings only (it loads with ``allow_pickle=False``):

=================  ==========================================================================
key                content
=================  ==========================================================================
``uv``             (N, 2) float64 map, one row per input row; (N, 3) unit vectors for a map
                   onto the sphere (``domain_json`` says ``"sphere"``)
``lambda_inv``     (N,) float64 inverse conformal factor
``center``         (3,) normalization translation
``scale``          () normalization scale, ``X_n = (X - center) / scale``
``config_json``    the resolved :class:`pcgeom.config.ParamConfig`
``history_json``   one record per stage (every loss term, sigma, alpha, batches, seconds)
``domain_json``    the domain, ``{"name": ..., **parameters}`` (:meth:`Domain.to_dict`)
``seed``           () int64
``version``        () str, the pcgeom version that wrote the file
``fingerprint``    () str, SHA-1 of the input coordinates (:func:`pcgeom.cloud.fingerprint`)
``seconds``        () float64 training time
``faces``          (M, 3) int64 reference faces of the input, when it had them (optional)
``denoise_json``   the noise estimate and what was done about it (optional,
                   :func:`pcgeom.denoise.denoise_points`'s record)
``fitted``         (N, 3) float64 the points the map was made of, when the cloud was
                   denoised (optional; input units and row order)
``mesh_faces``     (M, 3) int64 the local mesh the map was built on, its largest connected
                   part, as input rows (optional: the local-mesh maps)
``chart``          (N,) int64 the chart of each point, for a cut map (``cut="auto"``: its
                   ``uv`` is the atlas position in [0, 1]^2; optional)
``corner_uv``      (M, 3, 2) float64 the atlas position of each corner of ``mesh_faces``
                   (a seam vertex has one per side; optional, with ``chart``)
=================  ==========================================================================

Files written before ``domain_json``, ``seed`` and ``version`` existed still load, with a
warning that says what is unknown; files without ``mesh_faces`` load with ``mesh_faces``
None (``pcgeom param --out-mesh`` then rebuilds the local mesh). A ``uv`` of three columns
loads only with a ``domain_json`` that names the sphere.
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._version import __version__
from ..cloud import validate_faces
from ..config import ParamConfig, preset_name
from ..domains import Domain, get_domain
from ..errors import InputError, _one_line
from .atomic import check_readable, check_writable, write_atomic

__all__ = ["ParamResult"]

_OPTIONAL = ("lambda_inv", "center", "scale", "config_json", "history_json", "domain_json",
             "seed", "version")
"""Keys a full results file has; a file lacking some (older pcgeom, or a ``uv`` array from
another tool) loads with a warning naming them."""


@dataclass
class ParamResult:
    """A finished parametrization (NumPy arrays, one row per input point)."""

    uv: np.ndarray
    """(N, 2) float64 map of the normalized cloud, in the input's row order; (N, 3) unit
    vectors for a map onto the sphere (:attr:`pcgeom.domains.Domain.closed`)."""
    lambda_inv: np.ndarray | None
    """(N,) float64 inverse conformal factor l(x_i) (None for a bare ``uv`` file)."""
    center: np.ndarray | None
    """(3,) translation of the normalization (None for a bare ``uv`` file)."""
    scale: float | None
    """Scale of the normalization: ``X_n = (X - center) / scale``."""
    config: ParamConfig | None
    """The resolved config of the run (None for a bare ``uv`` file)."""
    domain: Domain | None = None
    """The parameter domain (None only for files written before it was stored)."""
    seed: int | None = None
    """The run's seed (None only for old files)."""
    history: list[dict] = field(default_factory=list)
    """One record per stage: schedule values, seconds and every loss term."""
    seconds: float = 0.0
    """Training time."""
    fingerprint: str | None = None
    """SHA-1 of the input coordinates (None for old files)."""
    version: str = __version__
    """pcgeom version that made the map ("unknown" for old files)."""
    faces: np.ndarray | None = None
    """(M, 3) reference faces of the input, kept only to evaluate the map."""
    denoise: dict | None = None
    """The noise estimate and what was done (:func:`pcgeom.denoise.denoise_points`'s record,
    ``noise_std`` and ``spacing`` in input units); None when denoising was off."""
    fitted: np.ndarray | None = None
    """(N, 3) float64 the points on the fitted surface that the map was made of (input units
    and rows), when the cloud was denoised; None otherwise."""
    mesh_faces: np.ndarray | None = None
    """(M, 3) int64 the triangles of the local mesh the map was built on (its largest
    connected part; after the normal rounds, the mesh they kept), as rows of the input (a
    duplicated point: its first row); None for the network maps and for files written
    before it was kept."""
    chart: np.ndarray | None = None
    """(N,) int64 the chart of each point, for a cut map (``cut="auto"``); None otherwise."""
    corner_uv: np.ndarray | None = None
    """(M, 3, 2) float64 per-corner atlas positions of ``mesh_faces`` for a cut map (seam
    vertices split in uv); None otherwise."""

    @property
    def preset(self) -> str:
        """Name of the preset the config equals, ``"custom"``, or ``"unknown"`` (no config)."""
        return "unknown" if self.config is None else preset_name(self.config)

    def save(self, path) -> Path:
        """Write the result to ``path`` (``.npz``) atomically; returns the path.

        Raises
        ------
        InputError
            ``path`` has another extension or cannot be written (:func:`check_writable`).
        """
        path = check_writable(path, "npz")
        if self.config is None or self.lambda_inv is None or self.center is None:
            raise ValueError("ParamResult.save: a result without config, lambda_inv or "
                             "normalization (a bare uv file) cannot be saved as a results file")
        arrays = {
            "uv": np.asarray(self.uv, dtype=np.float64),
            "lambda_inv": np.asarray(self.lambda_inv, dtype=np.float64),
            "center": np.asarray(self.center, dtype=np.float64),
            "scale": np.float64(self.scale),
            "config_json": np.str_(json.dumps(self.config.to_dict())),
            "history_json": np.str_(json.dumps(self.history)),
            "domain_json": np.str_(json.dumps(None if self.domain is None
                                              else self.domain.to_dict())),
            "seed": np.int64(-1 if self.seed is None else self.seed),
            "version": np.str_(self.version),
            "fingerprint": np.str_(self.fingerprint or ""),
            "seconds": np.float64(self.seconds),
        }
        if self.faces is not None:
            arrays["faces"] = np.asarray(self.faces, dtype=np.int64)
        if self.denoise is not None:
            arrays["denoise_json"] = np.str_(json.dumps(self.denoise))
        if self.fitted is not None:
            arrays["fitted"] = np.asarray(self.fitted, dtype=np.float64)
        if self.mesh_faces is not None:
            arrays["mesh_faces"] = np.asarray(self.mesh_faces, dtype=np.int64)
        if self.chart is not None:
            arrays["chart"] = np.asarray(self.chart, dtype=np.int64)
            arrays["corner_uv"] = np.asarray(self.corner_uv, dtype=np.float64)
        write_atomic(path, lambda f: np.savez_compressed(f, **arrays))
        return path

    @classmethod
    def load(cls, path, n_points: int | None = None, against: str = "the cloud") -> "ParamResult":
        """Read a map written by ``pcgeom param`` or :meth:`save`.

        A file with only a ``uv`` array (another tool's map), or with one unnamed array
        (``np.savez(path, uv)``: ``arr_0``), loads too, for evaluation.

        Parameters
        ----------
        path : str or os.PathLike
            A ``.npz`` results file.
        n_points : int, optional
            Rows the map must have (the points of the cloud or mesh it belongs to).
        against : str
            Name of that cloud or mesh, for the error message.

        Raises
        ------
        InputError
            Missing file, wrong extension, no ``uv`` array (the message lists the keys
            found), arrays of the wrong shape or with NaN, or a row count other than
            ``n_points``.

        Warns
        -----
        UserWarning
            A file without some of the keys a results file has (older pcgeom, or another
            tool): the message names what is unknown.
        """
        name = os.fspath(path)
        p = check_readable(path, "npz", "map")
        try:
            with np.load(p, allow_pickle=False) as archive:
                data = {key: archive[key] for key in archive.files}
        except Exception as exc:  # zipfile.BadZipFile, OSError, ValueError (pickled data), ...
            raise InputError(f"{name}: cannot parse: {_one_line(exc)}") from None
        if "uv" not in data and list(data) == ["arr_0"]:
            data = {"uv": data["arr_0"]}  # np.savez(path, uv): one unnamed array, a bare map
        if "uv" not in data:
            found = ", ".join(sorted(data)) or "none"
            raise InputError(f"{name}: no 'uv' array (found: {found}); "
                             "expected a map written by 'pcgeom param'")

        uv = data["uv"]
        if uv.ndim != 2 or uv.shape[1] not in (2, 3):
            raise InputError(f"{name}: 'uv' must have shape (N, 2), got {uv.shape}")
        if n_points is not None and len(uv) != n_points:
            raise InputError(f"{name}: map has {len(uv)} rows but {against} has {n_points} points")
        if not np.isfinite(uv).all():
            raise InputError(f"{name}: 'uv' contains NaN or inf")
        lambda_inv = data.get("lambda_inv")
        if lambda_inv is not None and lambda_inv.shape != (len(uv),):
            raise InputError(f"{name}: 'lambda_inv' must have shape ({len(uv)},), "
                             f"got {lambda_inv.shape}")
        try:
            config = (ParamConfig.from_dict(json.loads(str(data["config_json"])))
                      if "config_json" in data else None)
            history = json.loads(str(data["history_json"])) if "history_json" in data else []
            domain_spec = json.loads(str(data["domain_json"])) if "domain_json" in data else None
            domain = get_domain(domain_spec) if domain_spec is not None else None
            denoise = json.loads(str(data["denoise_json"])) if "denoise_json" in data else None
        except (ValueError, TypeError) as exc:  # JSONDecodeError and InputError are ValueErrors
            raise InputError(f"{name}: cannot parse its config, history or domain: "
                             f"{_one_line(exc)}") from None
        dim = 3 if domain is not None and domain.closed else 2
        if uv.shape[1] != dim:
            raise InputError(f"{name}: 'uv' must have shape (N, {dim})"
                             + (" for the domain sphere" if dim == 3 else "")
                             + f", got {uv.shape}")
        absent = [k for k in _OPTIONAL if k not in data]
        if absent:
            warnings.warn(f"{name}: written by an older pcgeom or another tool; unknown: "
                          f"{', '.join(k.removesuffix('_json') for k in absent)}", stacklevel=2)
        seed = int(data["seed"]) if "seed" in data else -1
        fitted = data.get("fitted")
        if fitted is not None and (fitted.shape != (len(uv), 3) or not np.isfinite(fitted).all()):
            raise InputError(f"{name}: 'fitted' must be finite, of shape ({len(uv)}, 3), "
                             f"got {fitted.shape}")
        mesh_faces = (validate_faces(data["mesh_faces"], len(uv), f"{name}: mesh_faces")
                      if "mesh_faces" in data else None)
        chart, corner_uv = data.get("chart"), data.get("corner_uv")
        if chart is not None:
            if chart.shape != (len(uv),) or corner_uv is None or mesh_faces is None \
                    or corner_uv.shape != (len(mesh_faces), 3, 2) \
                    or not np.isfinite(corner_uv).all():
                raise InputError(f"{name}: 'chart' must have shape ({len(uv)},), with "
                                 "finite 'corner_uv' of shape (M, 3, 2) for 'mesh_faces'")
        return cls(
            uv=uv.astype(np.float64),
            lambda_inv=None if lambda_inv is None else lambda_inv.astype(np.float64),
            center=np.asarray(data["center"], dtype=np.float64) if "center" in data else None,
            scale=float(data["scale"]) if "scale" in data else None,
            config=config,
            domain=domain,
            seed=None if seed < 0 else seed,
            history=history,
            seconds=float(data["seconds"]) if "seconds" in data else 0.0,
            fingerprint=(str(data["fingerprint"]) or None) if "fingerprint" in data else None,
            version=str(data["version"]) if "version" in data else "unknown",
            faces=validate_faces(data["faces"], len(uv), name) if "faces" in data else None,
            denoise=denoise,
            fitted=None if fitted is None else fitted.astype(np.float64),
            mesh_faces=mesh_faces,
            chart=None if chart is None else chart.astype(np.int64),
            corner_uv=None if chart is None else corner_uv.astype(np.float64),
        )
