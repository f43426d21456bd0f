"""Mechanics of packs: bonded contact networks, their exact elastic tensor, DEM, effective moduli.

Implements the bonded-particle model of §2.1 of 003_873b69fc71c74cf6.txt. Attributes are
imported lazily so ``import polypack.mechanics`` stays cheap.
"""

from __future__ import annotations

from importlib import import_module as _import_module

# name -> submodule; each helper adds its own lines (keep edits small).
_LAZY = {
    "BondNetwork": "network",
    "series_stiffness": "network",
    # effective moduli (t18): pure functions of phases and statistics
    "Phase": "effective",
    "dilute": "effective",
    "mori_tanaka": "effective",
    "hashin_shtrikman": "effective",
    "self_consistent": "effective",
    "three_point_bounds": "effective",
    "mefm": "interaction",
    # bonded DEM and the oscillatory shear test (t15)
    "oscillatory_shear": "dem",
    "relax": "dem",
    "ShearResult": "dem",
    "ShearInterrupted": "dem",
    "critical_time_step": "dem",
    "static_shear_modulus": "dem",
    # exact elastic tensor (t14)
    "elastic_tensor": "elastic",
    "ElasticTensor": "elastic",
    "voigt_average": "elastic",
    # full-field FFT homogenization of voxel images (issue 34)
    "homogenize": "fullfield",
    "Homogenized": "fullfield",
    # bonded networks out to OVITO, ParaView, LAMMPS (t22)
    "write_network": "export",
    "read_network": "export",
    "bond_forces": "export",
    "lammps_shear_input": "export",
    "fit_lammps_shear": "export",
    # rigidity: floppy modes, rigid clusters, load-bearing backbone, fabric (issue 36)
    "rigidity": "rigidity_analysis",
    "Rigidity": "rigidity_analysis",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        return getattr(_import_module(f"{__name__}.{_LAZY[name]}"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
