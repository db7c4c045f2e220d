"""A scratch calibration's result against its simulated truth, for the experiment scripts:
read(DIR) gives (estimate, truth, sigma), each [lever x, y, z (m), roll, pitch, heading (deg)],
from DIR/r.json (`mountcal calibrate --result`) and DIR/sim/truth.json (`mountcal simulate`);
sigma holds None where a parameter was held."""

import json


def read(d):
    r = json.load(open(d + "/r.json"))
    t = json.load(open(d + "/sim/truth.json"))["mounting"]
    truth = t["lever_arm_m"] + t["boresight_deg"]
    est = r["mounting"]["lever_arm_m"] + r["mounting"]["boresight_deg"]
    sig = r["sigma"]["lever_arm_m"] + r["sigma"]["boresight_deg"]
    return est, truth, sig
