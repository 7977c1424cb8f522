"""Prints py3gpp's NR sequences as JSON for tests/tests/nr_sequences.rs to compare bit for bit
with radar_sim::nr: the Gold sequence c(n) (nrPRBS), PSS, SSS, PBCH DMRS and its REs, and the
PDSCH DMRS (type 1, port 1000, n_SCID = 0, full band)."""

import json

import numpy as np
from py3gpp.configs.nrCarrierConfig import nrCarrierConfig
from py3gpp.configs.nrPDSCHConfig import nrPDSCHConfig
from py3gpp.nrPBCHDMRS import nrPBCHDMRS
from py3gpp.nrPBCHDMRSIndices import nrPBCHDMRSIndices
from py3gpp.nrPDSCHDMRS import nrPDSCHDMRS
from py3gpp.nrPRBS import nrPRBS
from py3gpp.nrPSS import nrPSS
from py3gpp.nrSSS import nrSSS


def cplx(values):
    v = np.asarray(values, dtype=complex)
    return {"re": v.real.tolist(), "im": v.imag.tolist()}


out = {
    "prbs": [
        {"c_init": c, "bits": [int(b) for b in nrPRBS(c, 600)]}
        for c in [0, 1, 2, 3, 1000, 12345, 2**20 + 7, 0x2AAAAAAA, 2**31 - 1]
    ],
    "pss": {str(c): [int(v) for v in nrPSS(c)] for c in range(3)},
    "sss": {str(c): [int(v) for v in nrSSS(c)] for c in range(1008)},
    "pbch_dmrs": [
        {"cell_id": c, "i_ssb_bar": i, **cplx(nrPBCHDMRS(c, i))}
        for c in [0, 1, 2, 3, 17, 503, 1006, 1007]
        for i in range(8)
    ],
    "pbch_dmrs_indices": {},
    "pdsch_dmrs": [],
}
for c in range(4):
    k, l = nrPBCHDMRSIndices(c, style="python")
    out["pbch_dmrs_indices"][str(c)] = {"k": [int(x) for x in k], "l": [int(x) for x in l]}

for scs, slot, nid, add_pos in [(15, 0, 0, 0), (30, 3, 300, 2), (60, 17, 65535, 3), (120, 79, 1, 1)]:
    carrier = nrCarrierConfig(NSizeGrid=52, NSlot=slot, SubcarrierSpacing=scs)
    pdsch = nrPDSCHConfig()
    pdsch.NSizeBWP = 52
    pdsch.NStartBWP = 0
    pdsch.PRBSet = list(range(52))
    pdsch.SymbolAllocation = [0, 14]
    pdsch.DMRS.DMRSAdditionalPosition = add_pos
    pdsch.DMRS.NIDNSCID = nid
    out["pdsch_dmrs"].append(
        {
            "slot": slot,
            "scrambling_id": nid,
            "additional_positions": add_pos,
            "prbs": 52,
            **cplx(nrPDSCHDMRS(pdsch, carrier)),
        }
    )

print(json.dumps(out))
