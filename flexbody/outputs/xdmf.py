"""XDMF time series for ParaView: the mesh once, then per step the point and cell data of
:func:`flexbody.outputs.fields.step_fields`, heavy data in an HDF5 file next to it (``FILE.xdmf.h5``).

Written through meshio's XDMF ``TimeSeriesWriter`` (meshio is in the ``mesh`` and ``dev`` extras and is
imported only here). The elements are ``triangle6`` cells (corners, then the midside nodes of edges (0,1),
(1,2), (2,0): the node order of flexbody, VTK and XDMF alike), on the reference positions; ParaView shows the
deformed shape with "Warp By Vector" on ``displacement``. The XML is rewritten and the HDF5 file flushed after
every step, so a run that stops leaves a readable series of the steps written so far.
"""

from __future__ import annotations

import os

import numpy as np


def heavy_data_path(path: str) -> str:
    """The HDF5 file that holds the arrays of the XDMF file ``path``."""
    return os.fspath(path) + ".h5"


class XdmfWriter:
    """Write a run as an XDMF time series; use as a context manager.

    Parameters
    ----------
    path : the .xdmf file (its arrays go to ``path + ".h5"``)
    mesh : anything with ``.nodes`` (n, 3) and ``.elements`` (m, 6)
    """

    def __init__(self, path, mesh):
        try:
            from meshio.xdmf.time_series import TimeSeriesWriter, write_xml
        except ImportError:
            raise ImportError("--xdmf needs meshio: pip install 'flexbody[mesh]' (or meshio)") from None
        import h5py
        self.path = os.fspath(path)
        self.heavy = heavy_data_path(self.path)
        self._write_xml = write_xml

        class _Writer(TimeSeriesWriter):
            def __enter__(inner):            # the arrays next to the .xdmf file, not in the working directory
                inner.h5_filename = self.heavy
                inner.h5_file = h5py.File(self.heavy, "w")
                return inner

        self._w = _Writer(self.path).__enter__()
        self.n_steps = 0
        try:
            self._w.write_points_cells(np.asarray(mesh.nodes, dtype=float),
                                       [("triangle6", np.asarray(mesh.elements, dtype=np.int64))])
            self._flush()
        except BaseException:
            self.close()
            raise

    def _flush(self) -> None:
        self._w.h5_file.flush()
        self._write_xml(self._w.filename, self._w.xdmf_file)

    def write_step(self, time: float, point_data: dict, cell_data: dict) -> None:
        """Append one step at ``time`` (the load factor of a static run, the time of a dynamic one)."""
        self._w.write_data(float(time), point_data={k: np.asarray(v, float) for k, v in point_data.items()},
                           cell_data={k: [np.asarray(v, float)] for k, v in cell_data.items()})
        self._flush()
        self.n_steps += 1

    @property
    def closed(self) -> bool:
        return self._w is None

    def close(self) -> None:
        """Write the XML and close the HDF5 file (idempotent)."""
        if self._w is not None:
            w, self._w = self._w, None
            try:
                w.__exit__(None, None, None)
            except Exception:
                if w.h5_file.id.valid:
                    w.h5_file.close()
                raise

    def __enter__(self) -> "XdmfWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
