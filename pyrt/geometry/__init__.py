"""Geometry: the Embree accelerator (the only embreex importer), mesh data, surface batches, ray offsets."""
from pyrt.geometry.accel import Accel, Hits
from pyrt.geometry.mesh_data import GeometryError, MeshData
from pyrt.geometry.surface import GeometryTable, SurfaceBatch, surface_from_hits

__all__ = ["Accel", "Hits", "GeometryError", "GeometryTable", "MeshData", "SurfaceBatch", "surface_from_hits"]
