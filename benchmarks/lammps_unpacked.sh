#!/bin/sh
# Unpack Debian's LAMMPS (and the OpenMPI it links) into a directory, without
# installing it: the system's mpiexec stays MPICH.  Prints the wrapper to pass
# to benchmarks/bench_lammps.py / bench_granular.py as LMP=... or --lmp.
#     sh benchmarks/lammps_unpacked.sh [DIR]      (default /tmp/lammps)
set -e
dir=${1:-/tmp/lammps}
mkdir -p "$dir/debs" "$dir/root"
cd "$dir/debs"
apt-get download lammps liblammps0 lammps-data libopenmpi3 openmpi-common openmpi-bin \
    libevent-pthreads-2.1-7 libfabric1 libfftw3-double3 libhwloc-plugins libkim-api2 \
    libmunge2 libpmix2 libpsm-infinipath1 libpsm2-2 libvoro++1 ocl-icd-libopencl1 >/dev/null 2>&1
for deb in *.deb; do dpkg -x "$deb" "$dir/root"; done
cat > "$dir/lmp" <<WRAP
#!/bin/sh
R=$dir/root
export LD_LIBRARY_PATH=\$R/usr/lib/x86_64-linux-gnu:\$R/usr/lib/x86_64-linux-gnu/openmpi/lib:\$LD_LIBRARY_PATH
export OPAL_PREFIX=\$R/usr PATH=\$R/usr/bin:\$PATH OMPI_MCA_mtl=^ofi,psm OMPI_MCA_btl=self,vader
exec \$R/usr/bin/lmp "\$@"
WRAP
chmod +x "$dir/lmp"
echo "$dir/lmp"
