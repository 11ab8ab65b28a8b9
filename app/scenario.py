"""The dashboard's whole state: one param class, no Panel import.

Numeric parameters carry only *soft* bounds (the slider range): a value typed outside them is
still offered to :class:`Scenario`, which checks it against :data:`ACCEPTED` (what the core and a
sane grid accept), restores the last good value and says why in :attr:`Scenario.message`. So a
bad value never reaches the core, never raises in the server, and the last good maps stay.
"""

from __future__ import annotations

import math
import types

import param

import core

#: Most stations a custom layout may have.
MAX_STATIONS = 8

#: Hard limits: name -> (lowest, highest, unit). Enforced by Scenario; sliders span less.
#: Depths (spec §7: z positive down, the sea surface at z = 0) are never negative: there is no sea
#: above the surface, whatever the field model.
ACCEPTED = {
    "Ph": (0.0, 1e5, "A·m"),
    "Pv": (0.0, 1e5, "A·m"),
    "Ph_b": (0.0, 1e5, "A·m"),
    "Pv_b": (0.0, 1e5, "A·m"),
    "k": (1e-3, 1e3, ""),
    "h": (0.0, 5000.0, "m"),
    "z": (0.0, 5000.0, "m"),
    "y": (-5000.0, 5000.0, "m"),
    "speed": (0.01, 100.0, "m/s"),
    "heading": (-180.0, 180.0, "°"),
    "d": (0.1, 5000.0, "m"),
    "d_ref": (0.1, 5000.0, "m"),
    "T": (1e-3, 1000.0, "s"),
    "sigma": (1e-3, 100.0, "S/m"),
    "noise": (1e-12, 1e-2, "V/m"),
    "steps": (1, 20, "instants"),
    "extent": (1.0, 10000.0, "m"),
    "z_min": (0.0, 5000.0, "m"),
    "z_max": (0.0, 5000.0, "m"),
    "resolution": (20, 400, "points per axis"),
    "threshold": (0.01, 1e5, "m"),
    "sea_depth": (0.5, 10000.0, "m"),
    "seabed_sigma": (0.0, 1000.0, "S/m"),
    # -- sensor kinds (issue 26): the magnetic moment vector and the magnetic noise
    "mx": (-1e7, 1e7, "A·m²"),
    "my": (-1e7, 1e7, "A·m²"),
    "mz": (-1e7, 1e7, "A·m²"),
    "noise_b": (1e-6, 1e3, "nT"),
    "noise_g": (1e-6, 1e3, "nT/m"),
    "mx_b": (-1e7, 1e7, "A·m²"),
    "my_b": (-1e7, 1e7, "A·m²"),
    "mz_b": (-1e7, 1e7, "A·m²"),
    # the Shape tab (seed 003, app/shape.py); not map inputs: app.compute.FIELDS leaves shape_* out
    "shape_height": (0.1, 20.0, "m"),
    "shape_radius": (0.05, 10.0, "m"),
    "shape_inner_height": (0.0, 20.0, "m"),
    "shape_inner_radius": (0.0, 10.0, "m"),
    "shape_roll": (-180.0, 180.0, "°"),
    "shape_pitch": (-180.0, 180.0, "°"),
    "shape_yaw": (-180.0, 180.0, "°"),
    "shape_mx": (-1000.0, 1000.0, "A·m² per cell"),
    "shape_my": (-1000.0, 1000.0, "A·m² per cell"),
    "shape_mz": (-1000.0, 1000.0, "A·m² per cell"),
    "shape_offset": (-100.0, 100.0, "m"),
    "shape_above": (-100.0, 100.0, "m"),
    "shape_noise": (1e-5, 10.0, "nT/m"),
    "shape_outlier_size": (0.0, 1e5, "σ"),
    "shape_runs": (1, 20, "passes"),
    "shape_seed": (0, 1_000_000, ""),
    # the Layout design tab's own numbers (not map inputs: app.compute.FIELDS leaves them out)
    "ellipse_x": (-5000.0, 5000.0, "m"),
    "ellipse_y": (-5000.0, 5000.0, "m"),
    "n_stations": (1, MAX_STATIONS, "stations"),
    # the Track tab (app/track.py); not map inputs either. A track longer than
    # app.track.MAX_STEPS steps (duration / T + 1) is refused by that tab, with a message.
    "track_x0": (-5000.0, 5000.0, "m"),
    "track_y0": (-5000.0, 5000.0, "m"),
    "track_heading": (-180.0, 180.0, "°"),
    "track_speed": (0.1, 50.0, "m/s"),
    "track_duration": (2.0, 600.0, "s"),
    "track_sigma_a": (0.0, 10.0, "m/s²"),
    "track_alpha": (0.0, 100.0, "moment²/step"),
    "track_runs": (1, 20, "runs"),
    # the Calibration tab (seed 004, app/calibration.py); its headings text is checked there
    "cal_roll_deg": (0.0, 45.0, "°"),
    "cal_pitch_deg": (0.0, 30.0, "°"),
    "cal_n_attitudes": (1, 120, "attitudes"),
    "cal_noise_nt": (0.1, 5000.0, "nT"),
    "cal_angle_noise_deg": (0.0, 2.0, "°"),
    "cal_be_n": (-1e5, 1e5, "nT"),
    "cal_be_e": (-1e5, 1e5, "nT"),
    "cal_be_d": (-1e5, 1e5, "nT"),
    "cal_iterations": (1, 5000, "iterations"),
    "cal_p0_bp_nt": (0.01, 1e6, "nT"),
    "cal_seed": (0, 1_000_000, ""),
}
#: Prefixes of the parameters of the tabs that are not the maps' (their numbers are in ACCEPTED
#: too, but no map is computed from them: app.compute.FIELDS leaves them out).
NOT_MAP_INPUTS = ("shape_", "track_", "cal_", "ellipse_", "n_stations")

MEASURE_LABELS = {
    "log10|det Γ| (paper)": "log10_det",
    "Observability index log10 η": "log10_eta",
    "D-optimal ½·log10 det F": "d_optimal",
    "CRLB position error (m)": "crlb_position",
}
COMPARISONS = {
    "Dual − single (Fig. 5)": "dual_vs_single",
    "Moments ×k − original (Fig. 3)": "moments_scaled",
    "Moment split B − A (Fig. 4)": "moment_split",
    "Spacing d − reference d (Fig. 6)": "spacing",
    "Sensor kind B − A (seed 003)": "sensor_kinds",
}
CRITERIA = {
    "Mean D-optimal over the region": "mean_dopt",
    "Worst-case D-optimal over the region": "worst_dopt",
    "Area with CRLB error under threshold": "area_crlb",
}
#: Error maps of the design tab: label -> core.CrlbErrors attribute.
ERROR_QUANTITIES = {
    "3-D position error (m)": "position",
    "Horizontal error, semi-major axis (m)": "semi_major",
    "Depth error σz (m)": "sigma_z",
    "Speed error σ|v| (m/s)": "sigma_speed",
}
#: Sensor kinds (spec §11, core.Sensor): label -> core kind.
SENSORS = {"electric (E, V/m)": "E", "magnetometer (B, nT)": "B", "gradiometer (G, nT/m)": "G",
           "magnetometer + gradiometer (BG)": "BG"}
#: Moments of a magnetic target named by the "moments known" state set.
MAGNETIC_KNOWN = ("mx", "my", "mz")
#: Measures that use the paper's square Γ (electric only): a magnetic kind moves off them.
SQUARE_MEASURES = ("log10|det Γ| (paper)", "Observability index log10 η")
#: Parameters that are depths below the sea surface (m): a negative value is above the surface.
DEPTHS = ("h", "z", "z_min", "z_max")
DIFFERENCES = {"log10 Δ|det| (paper, Δ ≤ 0 blank)": "paper", "Signed log-ratio": "ratio"}
MODELS = {"exact dipole": "exact", "paper eqs. (10)–(12) as printed": "paper"}
STATE_SETS = {"all 7 unknown": (), "moments known (5 states)": ("Ph", "Pv")}
SEA_MODELS = ("whole space", "layered")
#: Depth parameters that must lie in the water column [0, D] in a layered sea.
_COLUMN = ("z", "h", "z_min", "z_max")

_COMMON = dict(Ph=100.0, Pv=20.0, h=100.0, z=120.0, speed=2.0 * math.sqrt(2.0), heading=45.0,
               T=1.0, plane="x–y", extent=300.0, measure="log10|det Γ| (paper)",
               sea_model="whole space")
#: The paper's figures (spec §5) as parameter sets.
PRESETS = {
    "Fig. 1": dict(_COMMON, layout="single", comparison="Dual − single (Fig. 5)", d=15.0),
    "Fig. 2": dict(_COMMON, plane="x–z", y=50.0, z_min=100.0, z_max=400.0, layout="single",
                   comparison="Moment split B − A (Fig. 4)", Ph_b=100.0, Pv_b=100.0),
    "Fig. 3": dict(_COMMON, layout="single", comparison="Moments ×k − original (Fig. 3)", k=10.0),
    "Fig. 4": dict(_COMMON, layout="single", comparison="Moment split B − A (Fig. 4)",
                   Ph=100.0, Pv=0.0, Ph_b=70.7, Pv_b=70.7),
    "Fig. 5": dict(_COMMON, layout="dual", comparison="Dual − single (Fig. 5)", d=15.0),
    "Fig. 6": dict(_COMMON, layout="dual", comparison="Spacing d − reference d (Fig. 6)",
                   d=50.0, d_ref=10.0),
    # seed 001's sea trial (spec §8): 8.4 m of water, sensors 10 m apart on the seabed,
    # a 100 A·m horizontal source 0.2 m deep; its speed is not printed (2 m/s assumed)
    "Seed 001 sea trial": dict(sea_model="layered", sea_depth=8.4, seabed_sigma=0.4, sigma=4.0,
                               h=8.4, d=10.0, z=0.2, Ph=100.0, Pv=0.0, speed=2.0, heading=90.0,
                               T=1.0, plane="x–y", extent=300.0, layout="dual",
                               comparison="Dual − single (Fig. 5)", z_min=0.0, z_max=8.4,
                               measure="log10|det Γ| (paper)",
                               # along x, as core.dual_station(h, d) puts the Maps tab's pair: one
                               # geometry on every tab (it was along y here, along x on Maps)
                               stations=[[0.0, 0.0, 8.4], [10.0, 0.0, 8.4]]),
    # spec §11 at one station: magnetometer (A) against magnetometer + gradiometer (B); A alone
    # is rank 7 of 8 (veiled), B + G is observable. Switch A to the gradiometer to see it veiled too.
    "Seed 003 sensors": dict(_COMMON, measure="CRLB position error (m)", layout="single",
                             comparison="Sensor kind B − A (seed 003)",
                             sensor="magnetometer (B, nT)",
                             sensor_b="magnetometer + gradiometer (BG)", z=110.0, extent=60.0),
}

#: Which map shows each paper figure: preset -> (map index 0 A, 1 B, 2 difference, caption).
PAPER_MAPS = {
    "Fig. 1": ((0,), "map A is the paper's Fig. 1: log10|det Γ| of one station over x–y"),
    "Fig. 2": ((0, 1), "maps A and B are the paper's Fig. 2(a) (P_h > P_v) and 2(b) (P_h = P_v), x–z"),
    "Fig. 3": ((2,), "the difference map is the paper's Fig. 3: moments × 10 minus the original"),
    "Fig. 4": ((2,), "the difference map is the paper's Fig. 4(a): (70.7, 70.7) − (100, 0) A·m"),
    "Fig. 5": ((2,), "the difference map is the paper's Fig. 5(b): dual (d = 15 m) minus single"),
    "Fig. 6": ((2,), "the difference map is the paper's Fig. 6: dual d = 50 m minus d = 10 m"),
}


def _num(default, soft, label, doc, **kw):
    return param.Number(default, softbounds=soft, label=label, doc=doc, **kw)


class Scenario(param.Parameterized):
    """Everything a view needs to draw the maps."""

    # -- target and sources
    Ph = _num(100.0, (0, 1000), "P_h (A·m)", "Horizontal dipole moment of the target, A·m.")
    Pv = _num(20.0, (0, 1000), "P_v (A·m)", "Vertical dipole moment of the target, A·m.")
    speed = _num(2.0 * math.sqrt(2.0), (0.1, 20), "Speed (m/s)", "Target speed, m/s (> 0).")
    heading = _num(45.0, (-180, 180), "Heading (°)",
                   "Course over ground, degrees from +x towards +y; the horizontal dipole points along it.")
    # -- geometry
    plane = param.Selector(objects=["x–y", "x–z"], default="x–y", label="Map plane",
                           doc="x–y: horizontal plane at target depth z. x–z: vertical plane at fixed y.")
    z = _num(120.0, (0, 1000), "Target depth z (m)", "Target depth for the x–y plane, m (same axis as h).")
    y = _num(50.0, (-500, 500), "Fixed y (m)", "y of the x–z plane, m.")
    h = _num(100.0, (0, 1000), "Station depth h (m)", "Depth of every station, m.")
    d = _num(15.0, (0.5, 300), "Station spacing d (m)", "Station 2 sits at (d, 0, h); station 1 at (0, 0, h).")
    layout = param.Selector(objects=["single", "dual"], default="dual", label="Layout for Figs. 3–4",
                            doc="Station layout used by the moment comparisons.")
    # -- comparison
    comparison = param.Selector(objects=list(COMPARISONS), default="Dual − single (Fig. 5)", label="Compare",
                                doc="Which two scenarios the maps A and B and their difference show.")
    k = _num(10.0, (0.1, 100), "Moment factor k", "Fig. 3: B has both moments × k.")
    Ph_b = _num(70.7, (0, 1000), "B: P_h (A·m)", "Fig. 4: horizontal moment of scenario B, A·m.")
    Pv_b = _num(70.7, (0, 1000), "B: P_v (A·m)", "Fig. 4: vertical moment of scenario B, A·m.")
    d_ref = _num(10.0, (0.5, 300), "Reference spacing (m)", "Fig. 6: spacing of scenario A, m.")
    difference = param.Selector(objects=list(DIFFERENCES), default="log10 Δ|det| (paper, Δ ≤ 0 blank)",
                                label="Difference map", doc="How B is compared with A.")
    measure = param.Selector(objects=list(MEASURE_LABELS), default="log10|det Γ| (paper)", label="Measure",
                             doc="What the maps show.")
    # -- advanced
    T = _num(1.0, (0.1, 10), "Sample interval T (s)", "Time between measurements, s.")
    sigma = _num(4.0, (0.1, 10), "Conductivity σ (S/m)", "Sea conductivity, S/m; shifts log10|det Γ| only.")
    noise = _num(1e-7, (1e-9, 1e-5), "Sensor noise (V/m)", "Noise standard deviation per component, V/m.")
    steps = param.Integer(3, softbounds=(1, 10), label="Instants N (Fisher)",
                          doc="Number of instants for the Fisher measures.")
    model = param.Selector(objects=list(MODELS), default="exact dipole", label="Field model",
                           doc="'paper' reproduces the printed equations, which are not a dipole field.")
    state_set = param.Selector(objects=list(STATE_SETS), default="all 7 unknown", label="Unknown states",
                               doc="Treat the moments as known to make one station observable.")
    extent = _num(300.0, (10, 2000), "Half-width of x (and y) (m)", "Maps span ±extent in x (and y), m.")
    z_min = _num(100.0, (0, 1000), "x–z plane: z from (m)", "Shallowest target depth of the x–z plane, m.")
    z_max = _num(400.0, (0, 2000), "x–z plane: z to (m)", "Deepest target depth of the x–z plane, m.")
    resolution = param.Integer(200, softbounds=(20, 400), label="Grid points per axis",
                               doc="Map resolution; at most 400 per axis.")
    # -- layout design
    stations = param.List([[0.0, 0.0, 100.0], [15.0, 0.0, 100.0]], item_type=list,
                          label="Stations (x, y, z) (m)",
                          doc="Custom layout for the design tab: 1 to 8 stations anywhere, m.")
    criterion = param.Selector(objects=list(CRITERIA), default="Mean D-optimal over the region",
                               label="Spacing criterion", doc="What the best spacing maximises.")
    error_quantity = param.Selector(objects=list(ERROR_QUANTITIES), default="3-D position error (m)",
                                    label="Error map", doc="Which Cramér–Rao error the design map shows.")
    layout_kind = param.Selector(objects=["line", "triangle", "square", "free"], default="square",
                                 label="Optimise: layout shape",
                                 doc="Shape of the N-station layout to optimise ('free': any positions, slow).")
    n_stations = param.Integer(4, softbounds=(1, 8), label="Optimise: stations N",
                               doc="Number of stations of the layout to optimise, 1 to 8.")
    ellipse_x = param.Number(100.0, softbounds=(-1000.0, 1000.0),
                             label="Error ellipse at x (m)",
                             doc="x of the target whose horizontal error ellipse is drawn, m.")
    ellipse_y = param.Number(100.0, softbounds=(-1000.0, 1000.0),
                             label="Error ellipse at y (m)",
                             doc="y of the target whose horizontal error ellipse is drawn, m.")
    threshold = _num(10.0, (0.1, 100), "CRLB threshold (m)",
                     "For 'area within threshold': position error (1σ, m) that counts as good.")
    # -- the sea (spec §7)
    sea_model = param.Selector(objects=list(SEA_MODELS), default="whole space", label="Sea",
                               doc="Whole space (the paper) or layered: insulating air above, a "
                                   "seabed below; z and h are then depths in [0, D].")
    sea_depth = _num(200.0, (1, 500), "Sea depth D (m)", "Water depth D of the layered sea, m.")
    seabed_sigma = _num(1.0, (0, 10), "Seabed conductivity σb (S/m)",
                        "Conductivity of the seabed half-space, S/m (0: insulating).")
    # -- track tab (app/track.py): a straight track over the design tab's stations, at the
    # target depth z, with the target's moments, the sensor noise, σ and T above. Numbers are
    # refused outside ACCEPTED with a message; not map inputs (app.compute.FIELDS leaves them out).
    track_x0 = param.Number(-250.0, softbounds=(-1000.0, 1000.0),
                            label="Track start x (m)", doc="x of the track's start, m.")
    track_y0 = param.Number(-120.0, softbounds=(-1000.0, 1000.0),
                            label="Track start y (m)", doc="y of the track's start, m.")
    track_heading = param.Number(25.0, softbounds=(-180.0, 180.0), label="Track heading (°)",
                                 doc="Course of the straight track, degrees from +x towards +y.")
    track_speed = param.Number(2.0, softbounds=(0.1, 20.0),
                               label="Track speed (m/s)", doc="Target speed along the track, m/s.")
    track_duration = param.Number(250.0, softbounds=(10.0, 600.0),
                                  label="Track duration (s)",
                                  doc="Length of the track in time, s (one measurement every T).")
    track_axes = param.Selector(objects=[3, 2], default=3, label="Sensor axes",
                                doc="3: every station measures Ex, Ey, Ez; 2: horizontal Ex, Ey only.")
    track_sigma_a = param.Number(0.1, softbounds=(0.0, 1.0),
                                 label="Acceleration noise σa (m/s²)",
                                 doc="DWNA process noise per horizontal axis, m/s² (seed 001: 0.1).")
    track_alpha = param.Number(0.001, softbounds=(0.0, 0.1),
                               label="Moment random walk α (moment²/step)",
                               doc="Variance of the moments' random walk per step: (A·m)² for the "
                                   "electric dipole (seed 001: 0.001), (A·m²)² for a magnetic one.")
    track_filter = param.Selector(objects=["bank", "ekf", "puekf"], default="bank", label="Tracker",
                                  doc="bank: seed 001's 12 filters, no prior, ML selection; ekf / "
                                      "puekf: one filter from a prior about the truth.")
    track_runs = param.Integer(5, softbounds=(1, 20), label="Monte-Carlo runs",
                               doc="Noise realisations shown and averaged in the TRMSE, 1 to 20.")

    # -- sensor kinds (issue 26, spec §11): what every station measures. Electric: the moments
    # Ph, Pv (A·m) and the noise (V/m) above; magnetic: a free moment vector (A·m²), the noise
    # of the magnetometer (nT) and of the gradiometer (nT/m); a point gradient tensor.
    sensor = param.Selector(objects=list(SENSORS), default="electric (E, V/m)", label="Sensor",
                            doc="What every station measures: the electric field (the paper), the "
                                "magnetic field, its gradient tensor, or both (spec §11).")
    sensor_b = param.Selector(objects=list(SENSORS), default="magnetometer + gradiometer (BG)",
                              label="B: sensor", doc="Sensor comparison: the kind of scenario B.")
    mx = _num(-3000.0, (-20000, 20000), "m_x (A·m²)", "Magnetic moment of the target, x, A·m².")
    my = _num(1000.0, (-20000, 20000), "m_y (A·m²)", "Magnetic moment of the target, y, A·m².")
    mz = _num(5000.0, (-20000, 20000), "m_z (A·m²)", "Magnetic moment of the target, z (down), A·m².")
    mx_b = _num(0.0, (-20000, 20000), "B: m_x (A·m²)", "Moment split, magnetic: m_x of scenario B, A·m².")
    my_b = _num(0.0, (-20000, 20000), "B: m_y (A·m²)", "Moment split, magnetic: m_y of scenario B, A·m².")
    mz_b = _num(6000.0, (-20000, 20000), "B: m_z (A·m²)", "Moment split, magnetic: m_z of scenario B, A·m².")
    noise_b = _num(0.01, (1e-3, 10), "Magnetometer noise (nT)",
                   "Noise standard deviation per field component, nT.")
    noise_g = _num(0.01, (1e-3, 10), "Gradiometer noise (nT/m)",
                   "Noise standard deviation per tensor component, nT/m.")
    # -- shape tab (seed 003, app/shape.py): every name starts with shape_. A target (a grid of
    # 0.1 m dipole cells) passed by a gradiometer on a straight track along +x (start x = −40 m,
    # 5 m/s, 5 Hz, 81 samples); the defaults are seed 003's Fig. 4 (core.shape.cases). Numbers
    # are refused outside ACCEPTED; rules between them (cavity inside, type vs H and R, the
    # track clear of the target, the outliers' text) are said by the tab (app.shape.case_of).
    shape_type = param.Selector(objects=["cylinder", "disc"], default="cylinder", label="Target type",
                                doc="Seed 003: a cylinder has H > R (read as a line), a disc H ≤ R "
                                    "(read as a plane). Switching sets typical sizes if H, R disagree.")
    shape_height = _num(3.0, (0.1, 6.0), "Height H (m)", "Target height H along its axis, m.")
    shape_radius = _num(0.5, (0.05, 3.0), "Radius R (m)", "Target radius R, m.")
    shape_inner_height = _num(0.0, (0.0, 6.0), "Cavity height H_in (m, 0: solid)",
                              "Hollow target: height of the coaxial cavity, m (0 with R_in = 0: solid).")
    shape_inner_radius = _num(0.0, (0.0, 3.0), "Cavity radius R_in (m, 0: solid)",
                              "Hollow target: radius of the coaxial cavity, m (< R).")
    shape_roll = _num(30.0, (-180, 180), "Roll θ (°)", "Attitude: roll about x, degrees (R = Rz·Ry·Rx).")
    shape_pitch = _num(45.0, (-180, 180), "Pitch β (°)", "Attitude: pitch about y, degrees.")
    shape_yaw = _num(60.0, (-180, 180), "Yaw φ (°)", "Attitude: yaw about z, degrees.")
    shape_mx = _num(-3.0, (-10, 10), "Cell moment mx (A·m²)", "Moment of each 0.1 m cell, x (A·m²).")
    shape_my = _num(1.0, (-10, 10), "Cell moment my (A·m²)", "Moment of each 0.1 m cell, y (A·m²).")
    shape_mz = _num(5.0, (-10, 10), "Cell moment mz (A·m²)", "Moment of each 0.1 m cell, z (A·m²).")
    shape_offset = _num(5.0, (-30, 30), "Track lateral offset y (m)",
                        "y of the straight track along x (the target's centre is the origin), m.")
    shape_above = _num(5.0, (-30, 30), "Track height above the target (m)",
                       "Height of the track above the target's centre, m (z = −height: z is down).")
    shape_noise = param.Number(0.01, softbounds=(1e-3, 1.0), label="Noise σ (nT/m)",
                               doc="Gaussian noise of each tensor component, nT/m (seed 003: 0.01).")
    shape_outliers = param.String("", label="Outliers at platform x (m)",
                                  doc="Comma-separated x positions (m) of the samples that get an "
                                      "outlier on all five components (Fig. 5: −20, −10, 0); empty: none.")
    shape_outlier_size = _num(500.0, (0, 2000), "Outlier size (σ)",
                              "Added to each hit component, in units of the noise σ (Fig. 5: 500).")
    shape_window = param.Selector(objects=["one sample", "seed 003 window (lag 5)"],
                                  default="one sample", label="Filter update",
                                  doc="One sample: the honest update. Seed 003's window of three lagged "
                                      "readings (eq. 15): every sample counts three times.")
    shape_runs = param.Integer(1, softbounds=(1, 20), label="Monte-Carlo passes",
                               doc="Noise realisations: errors and shape are their medians, 1 to 20.")
    shape_seed = param.Integer(0, softbounds=(0, 100), label="Random seed", doc="Seed of the noise.")

    @param.depends("shape_type", watch=True)
    def _shape_type_sizes(self):
        """A type the sizes disagree with (a cylinder has H > R, a disc H ≤ R) sets the type's
        typical sizes (seed 003's cylinder, Table 5's disc) and a solid body, and says so."""
        if self._restoring:
            return
        cylinder = self.shape_type == "cylinder"
        if (self.shape_height > self.shape_radius) == cylinder:
            return
        H, R = (3.0, 0.5) if cylinder else (0.3, 1.0)
        self._quietly(shape_height=H, shape_radius=R, shape_inner_height=0.0, shape_inner_radius=0.0)
        self.param.update(message=f"{self.shape_type.capitalize()}: set H = {H:g} m, R = {R:g} m, "
                                  "solid (the sizes were the other type's).", refused=["shape_type"])

    # -- feedback
    message = param.String("", doc="Why the last input was refused (plain text).")
    refused = param.List([], item_type=str,
                         doc="The parameters the message is about (shown next to their inputs); "
                             "empty for a message about the page's link.")

    # -- calibration tab (seed 004, app/calibration.py): every name starts with cal_. Numbers are
    # refused outside ACCEPTED with a message; the headings text is parsed, and refused, by that tab.
    cal_source = param.Selector(
        objects=["Designed manoeuvre", "Seed 004 simulation", "Seed 004 Table 1", "Uploaded CSV"],
        default="Seed 004 simulation", label="Calibration data",
        doc="Designed or simulated manoeuvres use seed 004's simulated ship (K, Bp) as the truth.")
    cal_convention = param.Selector(
        objects=list(core.calibration.CONVENTIONS), default="seed004", label="Attitude convention",
        doc="How heading, roll and pitch make A (core.calibration.CONVENTIONS); seed004 is its eq. (2).")
    cal_headings = param.String("0, 90, 180, 270", label="Headings (°)",
                                doc="Designed manoeuvre: headings sailed in turn, degrees from north.")
    cal_roll_deg = param.Number(10.0, softbounds=(0.0, 45.0), label="Roll amplitude (°)",
                                doc="Designed manoeuvre: roll = amplitude · cos(2πn/N), degrees.")
    cal_pitch_deg = param.Number(5.0, softbounds=(0.0, 30.0), label="Pitch amplitude (°)",
                                 doc="Designed manoeuvre: pitch = amplitude · sin(2πn/N), degrees.")
    cal_n_attitudes = param.Integer(12, softbounds=(1, 120), label="Attitudes N",
                                    doc="Number of attitudes of a designed or simulated manoeuvre.")
    cal_noise_nt = param.Number(100.0, softbounds=(0.1, 5000.0), label="Reading error bound ± (nT)",
                                doc="Uniform reading errors within ± this, nT; the filter and the CRLB "
                                    "use σ = bound/√3.")
    cal_angle_noise_deg = param.Number(0.05, softbounds=(0.0, 2.0), label="Angle error bound ± (°)",
                                       doc="Uniform errors of each recorded angle within ± this, degrees.")
    cal_be_n = param.Number(34000.0, softbounds=(-1e5, 1e5), label="Be north (nT)",
                            doc="Geomagnetic field, north component, nT.")
    cal_be_e = param.Number(2000.0, softbounds=(-1e5, 1e5), label="Be east (nT)",
                            doc="Geomagnetic field, east component, nT.")
    cal_be_d = param.Number(35000.0, softbounds=(-1e5, 1e5), label="Be down (nT)",
                            doc="Geomagnetic field, down component, nT.")
    cal_iterations = param.Integer(600, softbounds=(1, 5000), label="Kalman iterations",
                                   doc="Filter steps; the readings are reused cyclically (seed 004).")
    cal_p0_bp_nt = param.Number(3000.0, softbounds=(0.01, 1e6), label="Prior σ of Bp in P(0) (nT)",
                                doc="Square root of P(0)'s Bp entry, nT (K entries: 1). Small values "
                                    "slow the filter down.")
    cal_seed = param.Integer(4, softbounds=(0, 1_000_000), label="Random seed",
                             doc="Seed of the simulated attitudes and errors.")

    def __init__(self, **params):
        # Hard limits hold from the start: a bad value given here falls back to the default.
        notes = [n for n in (self.problem(k, v) for k, v in params.items() if k in ACCEPTED) if n]
        params = {k: v for k, v in params.items() if k not in ACCEPTED or self.problem(k, v) is None}
        super().__init__(**params)
        if notes:
            self.message = "; ".join(notes) + ". Used the default."
        self._restoring = False
        self.param.watch(self._check, list(ACCEPTED))
        self.param.watch(self._check_stations, ["stations"])

    def _check(self, *events):
        """Restore the last good value of any parameter set outside ACCEPTED, and say so."""
        if self._restoring:
            return
        notes = [p for p in (self.problem(ev.name, ev.new) for ev in events) if p]
        moved = {}  # stations on the seabed stay there when D changes
        for ev in events:
            if ev.name == "sea_depth" and not notes and self.sea_model == "layered":
                moved = self._follow_seabed(ev.old, ev.new)
                self._quietly(**moved)
        if not notes and self.z_min >= self.z_max:
            notes.append("x–z plane: 'z to' must be deeper than 'z from'")
        if not notes:
            notes = self.column_problems()
        if not notes:
            if self.message:
                self.param.update(message="", refused=[])
            return
        back = {ev.name: ev.old for ev in events}
        old_depth = back.get("sea_depth")
        if moved:
            back.update(self._follow_seabed(self.sea_depth, old_depth))
        self._quietly(**back)
        self.param.update(message="; ".join(notes) + ". Kept the last good value.",
                          refused=[ev.name for ev in events])

    def column_problems(self, stations=None, names=_COLUMN):
        """In a layered sea, why depths (and custom stations) are outside [0, D]; else []."""
        if self.sea_model != "layered":
            return []
        D = self.sea_depth
        notes = [f"{Scenario.param[n].label} = {getattr(self, n):g} m is outside the water column "
                 f"0 … {D:g} m" for n in names if not 0.0 <= getattr(self, n) <= D]
        notes += [f"Station {i + 1} depth {st[2]:g} m is outside the water column 0 … {D:g} m"
                  for i, st in enumerate(self.stations if stations is None else stations)
                  if not 0.0 <= st[2] <= D]
        return notes[:1]

    def _quietly(self, **values):
        self._restoring = True
        try:
            self.param.update(values)
        finally:
            self._restoring = False

    @param.depends("sea_model", watch=True)
    def _to_the_seabed(self):
        """Switching to a layered sea puts the stations on the seabed (h = D), the target and
        the x–z plane into the water column, and the field model to the exact dipole (the
        paper's printed equations have no images)."""
        if self.sea_model != "layered" or self._restoring:
            return
        D = self.sea_depth
        moved = dict(h=D, z=min(max(self.z, 0.0), D), z_min=0.0, z_max=D, model="exact dipole",
                     stations=[[st[0], st[1], D] for st in self.stations])
        said = [f"{Scenario.param[n].label.split(' (')[0]} {getattr(self, n):g} → {moved[n]:g} m"
                for n in ("h", "z", "z_min", "z_max") if getattr(self, n) != moved[n]]
        if moved["stations"] != self.stations:
            said.append(f"custom stations to the seabed ({D:g} m)")
        if self.model != "exact dipole":
            said.append("field model → exact dipole (the paper's printed equations have no images)")
        self._quietly(**moved)
        note = ("Layered sea: moved " + "; ".join(said) + ". These stay when you switch back to the "
                "whole space." if said else "")
        self.param.update(message=note, refused=["sea_model"] if note else [])

    @param.depends("sensor", "sensor_b", "comparison", "measure", watch=True, on_init=True)
    def _all_rows_for_magnetic(self):
        """A magnetic kind on the maps moves the measure off the paper's square-Γ rule (the
        electric paper's, refused by core for magnetic kinds) to the CRLB, and says so."""
        if getattr(self, "_restoring", False) or self.measure not in SQUARE_MEASURES or not self.magnetic_maps():
            return
        self._quietly(measure="CRLB position error (m)")
        self.param.update(message=f"{self.param['measure'].label}: the paper's square-Γ rule is the electric "
                                  "paper's; magnetic sensors use all rows of N instants: measure → CRLB "
                                  "position error.",
                          refused=["sensor" if SENSORS[self.sensor] != "E" else "sensor_b"])

    def magnetic_maps(self):
        """Whether map A or B measures with a magnetic kind."""
        return SENSORS[self.sensor] != "E" or (COMPARISONS[self.comparison] == "sensor_kinds"
                                               and SENSORS[self.sensor_b] != "E")

    @param.depends("model", watch=True)
    def _exact_in_a_sea(self):
        if self.sea_model == "layered" and self.model != "exact dipole" and not self._restoring:
            self._quietly(model="exact dipole")
            self.param.update(message="The paper's printed equations have no layered-sea form: "
                                      "use the whole space.", refused=["model"])

    def _follow_seabed(self, old, new):
        """Values that sat on the old seabed (h, z_max, custom stations), moved to the new one."""
        moved = {n: new for n in ("h", "z_max") if getattr(self, n) == old}
        stations = [[st[0], st[1], new if st[2] == old else st[2]] for st in self.stations]
        if stations != self.stations:
            moved["stations"] = stations
        return moved

    def _check_stations(self, event):
        if self._restoring:
            return
        problem = self.stations_problem(event.new) or next(iter(self.column_problems(event.new, ())), None)
        if problem:
            self._restoring = True
            try:
                self.stations = event.old
            finally:
                self._restoring = False
            self.param.update(message=problem + ". Kept the last good layout.", refused=["stations"])
        elif not self._restoring and self.message:
            self.param.update(message="", refused=[])

    @staticmethod
    def stations_problem(value):
        """None if ``value`` is 1–8 finite (x, y, z) positions within the accepted range (z: a depth,
        0 … 5000 m), else why."""
        lo, hi, _ = ACCEPTED["y"]
        if not 1 <= len(value) <= MAX_STATIONS:
            if len(value) > MAX_STATIONS:
                return f"At most {MAX_STATIONS} stations: a {len(value)}th was refused"
            return f"A layout needs 1 to {MAX_STATIONS} stations; got {len(value)}"
        for i, st in enumerate(value):
            ok = len(st) == 3 and all(isinstance(c, (int, float)) and not isinstance(c, bool)
                                      and math.isfinite(c) and lo <= c <= hi for c in st)
            if not ok:
                return (f"Station {i + 1} must be three numbers (x, y, z) in {lo:g} … {hi:g} m; "
                        f"got {str(st)[:60]!r}")
            if st[2] < 0:
                return (f"Station {i + 1}: depth z = {st[2]:g} m is above the sea surface; depths are "
                        f"measured down from the surface (z ≥ 0)")
        return None

    @staticmethod
    def problem(name, value):
        """None if ``value`` is acceptable for ``name``, else a plain-text reason."""
        lo, hi, unit = ACCEPTED[name]
        label = Scenario.param[name].label
        is_int = isinstance(Scenario.param[name], param.Integer)
        ok_type = isinstance(value, int) if is_int else isinstance(value, (int, float))
        if isinstance(value, bool) or not ok_type or not math.isfinite(value):
            kind = "a whole number" if is_int else "a number"
            return f"{label} must be {kind}; got {str(value)[:40]!r}"
        if name in DEPTHS and value < 0:
            return (f"{label} = {value:.10g} is above the sea surface: depths are measured down from "
                    f"the surface, {lo:g} … {hi:g} {unit}")
        if not lo <= value <= hi:
            # the value to 10 digits: "100000" for 100000.1 read as if the bound had been refused
            return f"{label} = {value:.10g} is outside the accepted range {lo:g} … {hi:g} {unit}".rstrip()
        return None

    def apply_preset(self, name):
        """Load one of :data:`PRESETS` as a complete scenario: every parameter of the maps, the
        design and the track is the preset's or its default, whatever was set before (a preset
        used to be a diff of the previous one: custom stations, the x–z range and the sea of the
        previous preset stayed). The calibration inputs (seed 004's own problem, with presets of
        its own) are left alone."""
        self.param.update(preset_values(name))

    def active_preset(self):
        """The paper figure (a :data:`PRESETS` name) whose parameters the scenario holds, or None."""
        return preset_of(self)

    # -- what the core needs
    def core_plane(self):
        n = int(self.resolution)
        if self.plane == "x–y":
            return core.Plane("xy", (-self.extent, self.extent), (-self.extent, self.extent), self.z, n)
        return core.Plane("xz", (-self.extent, self.extent), (self.z_min, self.z_max), self.y, n)

    def velocity(self):
        return core.velocity_from_heading(self.speed, self.heading)

    def core_options(self, kind=None):
        """Keywords of core's map functions for sensor ``kind`` (a :data:`SENSORS` value; default
        the scenario's): the electric medium, or a magnetic ``core.Sensor`` (its noise in nT and
        nT/m; a static field does not see the sea)."""
        kind = SENSORS[self.sensor] if kind is None else kind
        known = STATE_SETS[self.state_set]
        # as the Scenario moves it (_all_rows_for_magnetic): also for values without the watcher
        # (a design snapshot holds no measure; its default is the paper's)
        measure = ("crlb_position" if self.measure in SQUARE_MEASURES and self.magnetic_maps()
                   else MEASURE_LABELS[self.measure])
        common = dict(T=self.T, steps=int(self.steps), measure=measure)
        if kind != "E":
            noise = {"B": self.noise_b, "G": self.noise_g, "BG": (self.noise_b, self.noise_g)}[kind]
            return dict(common, known=MAGNETIC_KNOWN if known else (), sensor=core.Sensor(kind, noise))
        sea = core.Sea(self.sea_depth, self.seabed_sigma) if self.sea_model == "layered" else None
        return dict(common, sigma=self.sigma, model=MODELS[self.model], known=known,
                    noise=self.noise, sea=sea)

    def moments(self, kind=None):
        """The target's moments for sensor ``kind``: (P_h, P_v) A·m, or (m_x, m_y, m_z) A·m²."""
        kind = SENSORS[self.sensor] if kind is None else kind
        return (self.Ph, self.Pv) if kind == "E" else (self.mx, self.my, self.mz)


#: Parameters a paper-figure preset does not set: feedback, and the calibration tab's own problem.
NOT_IN_PRESETS = ("name", "message", "refused")
#: Prefixes of tabs with problems (and presets) of their own, left alone by a paper-figure preset.
OWN_PRESETS = ("cal_", "shape_")


def preset_values(name):
    """Every parameter :meth:`Scenario.apply_preset` sets for preset ``name``: its values over
    the defaults of every parameter but the calibration tab's and the feedback."""
    defaults = {n: p.default for n, p in Scenario.param.objects().items()
                if n not in NOT_IN_PRESETS and not n.startswith(OWN_PRESETS)}
    return {**defaults, **{k: [list(v) for v in val] if k == "stations" else val
                           for k, val in PRESETS[name].items()}}


def preset_of(values, names=None):
    """The first :data:`PRESETS` name whose parameters ``values`` (attributes) all hold, or None.
    ``names``: compare only these parameters (a map snapshot holds only what the maps use)."""
    for name, preset in PRESETS.items():
        if all(getattr(values, k) == v for k, v in preset.items() if names is None or k in names):
            return name
    return None


class ScenarioValues(types.SimpleNamespace):
    """A scenario's values, read-only use, with the methods that build core's inputs: what the
    map computations need, without building a Scenario (its parameters, checks and watchers took
    a few ms of Python, under the GIL, for every map of every session)."""

    core_plane = Scenario.core_plane
    velocity = Scenario.velocity
    core_options = Scenario.core_options
    moments = Scenario.moments
    magnetic_maps = Scenario.magnetic_maps

    @classmethod
    def of(cls, values):
        """Every parameter's default, overridden by ``values`` (already accepted by a Scenario)."""
        return cls(**{**{name: p.default for name, p in Scenario.param.objects().items()}, **values})
