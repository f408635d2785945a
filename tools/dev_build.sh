#!/usr/bin/env bash
# Developer build into a private virtualenv and build folder, so several people can
# build one checkout at once: tools/dev_build.sh NAME  ->  /tmp/pcl_rg-NAME/venv
# Then run tests with /tmp/pcl_rg-NAME/venv/bin/python -m pytest ...
set -euo pipefail
name=${1:?usage: tools/dev_build.sh NAME}
root=/tmp/pcl_rg-$name
cd "$(dirname "$0")/.."
if [ ! -x "$root/venv/bin/python" ]; then
    python3 -m venv "$root/venv"
    "$root/venv/bin/pip" install -q "scikit-build-core>=0.10" "pybind11>=2.13" "cmake>=3.18" ninja \
        numpy scipy tqdm pytest hypothesis "laspy[lazrs]" matplotlib "dask[distributed]" ruff
fi
"$root/venv/bin/pip" install -q --no-deps --no-build-isolation -Cbuild-dir="$root/build" .
