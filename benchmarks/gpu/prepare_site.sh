#!/bin/bash
# Prepares what benchmarks/gpu/real_and_realistic.sh needs on a lent GPU
# whose image has JAX, flax, optax, xarray, h5py and scipy but not BLE, gin,
# gym, opensimplex, s2sphere, future, h5netcdf nor eccodes (KINDS.md):
#   gpu_site/  BLE 1.0.1 (its unused perciatelli44.pb left out) and the pure-
#              Python packages above, copied as source from this venv, and
#              h5netcdf from its wheel (--h5netcdf_wheel); on PYTHONPATH there;
#   gpu_data/  ../shared/realdata, and gfs_global.nc: the GRIB2 analysis
#              decoded here (decode_grib.py: eccodes does not fit the transfer),
#              whose arrays' SHA-256 goes into gpu_data/gfs_global.sha256.
# Both folders are git-ignored (.git/info/exclude); the device call carries
# them. Usage, in the checkout: bash benchmarks/gpu/prepare_site.sh H5NETCDF_WHEEL
set -euo pipefail
wheel=${1:?usage: prepare_site.sh H5NETCDF_WHEEL}
site_packages=$(.venv/bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
rm -rf gpu_site gpu_data
mkdir -p gpu_site gpu_data
for p in balloon_learning_environment gin gym gym_notices opensimplex s2sphere future transitions; do
  cp -r "$site_packages/$p" gpu_site/
done
find gpu_site -name __pycache__ -prune -exec rm -rf {} +
rm gpu_site/balloon_learning_environment/models/perciatelli44.pb
(cd gpu_site && unzip -q "$OLDPWD/$wheel" 'h5netcdf/*')
cp -r ../shared/realdata gpu_data/realdata
chmod -R u+w gpu_data
.venv/bin/python benchmarks/gpu/decode_grib.py \
  gpu_data/realdata/winds/gfs_2011-10-08T00Z_f072_global_2p5deg.grib2 \
  gpu_data/gfs_global.nc > gpu_data/gfs_global.sha256
du -sh gpu_site gpu_data
