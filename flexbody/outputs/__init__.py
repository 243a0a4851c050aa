"""Run outputs that hang off the side of a simulation: HDF5 results files and rerun recordings.

The core never imports this package. ``flexbody.outputs.hdf5`` needs only numpy and h5py;
``flexbody.outputs.rerun_log`` imports the rerun SDK only when a ``RerunLogger`` is created.
"""
