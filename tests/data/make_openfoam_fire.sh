#!/usr/bin/env bash
# Makes tests/data/openfoam_fire/: a real OpenFOAM case (Debian's `openfoam` 1912 package,
# buoyantPimpleFoam) — the heatTransfer/buoyantPimpleFoam/hotRoom tutorial of `openfoam-examples`
# made small and hot: a 2 × 3 × 2 m room (y up, gravity −y), 12 × 18 × 12 cells graded 2:1 in y,
# laminar, a 1600 K block of gas (0.8 × 1.2 × 0.8 m) on a 1600 K floor patch, 20 steps of 0.02 s written every
# 5 (times 0, 0.1, 0.2, 0.3, 0.4), gzip-compressed; only T and U are kept.
# Not part of setup: apt-get install openfoam openfoam-examples, then run this (about a minute).
set -euo pipefail
out=$(cd "$(dirname "$0")" && pwd)/openfoam_fire
work=$(mktemp -d)
cp -r /usr/share/doc/openfoam-examples/examples/heatTransfer/buoyantPimpleFoam/hotRoom "$work/case"
cd "$work/case"
export WM_PROJECT_DIR=/usr/share/openfoam  # where Debian's OpenFOAM finds its etc/ files
sed -i 's/^scale .*/scale   0.2;/; s/(\([0-9]*\) 5 \([0-9]*\))/(\1 15 \2)/g' system/blockMeshDict
sed -i 's/(20 10 20) simpleGrading (1 1 1)/(12 18 12) simpleGrading (1 2 1)/' system/blockMeshDict
sed -i 's/^endTime .*/endTime         0.4;/; s/^deltaT .*/deltaT          0.02;/' system/controlDict
sed -i 's/^writeInterval .*/writeInterval   5;/; s/^writeCompression .*/writeCompression on;/' \
    system/controlDict
cat > system/setFieldsDict <<'DICT'
FoamFile { version 2.0; format ascii; class dictionary; object setFieldsDict; }
defaultFieldValues ( volScalarFieldValue T 300 );
regions
(
    boxToCell { box (0.6 0 0.6) (1.4 1.2 1.4); fieldValues ( volScalarFieldValue T 1600 ); }
    boxToFace { box (0.6 -1 0.6) (1.4 1e-5 1.4); fieldValues ( volScalarFieldValue T 1600 ); }
);
DICT
sed -i 's/^simulationType .*/simulationType laminar;/' constant/turbulenceProperties
cp -r 0.orig 0
blockMesh > log.blockMesh
setFields > log.setFields
buoyantPimpleFoam > log.buoyantPimpleFoam
tail -3 log.buoyantPimpleFoam
rm -rf "$out" && mkdir -p "$out"
cp -r system constant "$out/"
for t in 0 0.1 0.2 0.3 0.4; do
    mkdir -p "$out/$t"
    for f in T U; do cp "$t/$f"* "$out/$t/"; done
done
rm -rf "$work"
touch "$out/case.foam"  # the empty marker file ParaView opens a case by
echo "wrote $out ($(du -sh "$out" | cut -f1))"
