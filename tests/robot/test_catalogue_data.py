"""Issue 25, item 1: the drive catalogue checked against physics and its own sources.

Each test names the item-1 error of the first catalogue (entered from memory) that it would
have caught, or says that it catches none of them and what it guards instead. The physics
checks hold for every entry; the data-sheet checks compare with values transcribed from the
documents the entries name.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from armlab.errors import RobotDescriptionError
from armlab.robot.catalogue import MINOR_FIELDS, load_catalogue, usable
from armlab.robot.catalogue_doc import catalogue_markdown
from armlab.robot.drives import RPM_TO_RAD_S, Motor, Reducer
from armlab.robot.drives_file import read_drives

REPO = Path(__file__).resolve().parents[2]
TEACHBOT6 = REPO / "robot_desc" / "teachbot6" / "drives.toml"
JOINTS = [f"joint{i}" for i in range(1, 7)]

#: mechanical time constant R J / Kt^2 of a real motor [s]: from a fraction of a millisecond
#: (small coreless and servo motors) to the 20 ms the thesis assumes for its torque motors
TAU_M_RANGE_S = (2e-4, 0.05)


@pytest.fixture(scope="module")
def cat():
    return load_catalogue()


def _read(part, *names: str) -> bool:
    """True when none of ``names`` is an estimated field of ``part``."""
    return not set(names) & set(part.estimated)


def test_every_entry_names_its_source_and_lists_real_fields(cat):
    """Every entry has a source; every estimated name is a field; mass and price are never what
    makes a part unusable. Would have caught: "most entries could not be checked against any
    source" (no entry said what was not read)."""
    motor_fields = set(Motor.__dataclass_fields__)
    reducer_fields = set(Reducer.__dataclass_fields__)
    for parts, names in ((cat.motors, motor_fields), (cat.reducers, reducer_fields)):
        for p in parts:
            assert len(p.source) > 40, p.model
            assert set(p.estimated) <= names, p.model
            assert usable(p) == (not set(p.estimated) - set(MINOR_FIELDS)), p.model
    assert sum(usable(m) for m in cat.motors) >= 2
    assert sum(usable(r) for r in cat.reducers) >= 4


def test_kt_equals_ke_in_si(cat):
    """Kt [N m/A] = Ke [V s/rad] for every motor (power balance of the ideal machine). None of
    item 1's errors breaks it; it catches a Ke copied in V/krpm or line-to-line (the AKM and
    smart-servo entries state Ke = Kt as a rule)."""
    for m in cat.motors:
        assert m.torque_constant_Nm_A == pytest.approx(m.back_emf_V_s_rad, rel=0.01), m.model


def test_listed_speed_within_the_voltage(cat):
    """Rated speed <= no-load speed U / Ke. None of item 1's errors breaks it (the AKM42E's
    2400 rpm stays below U / Ke = 2829 rpm; the next test catches it); it catches a speed
    of another winding or voltage."""
    for m in cat.motors:
        assert m.rated_speed_rad_s <= m.supply_voltage_V / m.back_emf_V_s_rad * 1.0001, m.model


def test_akm_rated_speed_follows_the_catalogue_rule(cat):
    """The AKM entries' rated speed is set by the rule their source states, 0.8 U / Ke
    (hand calculation for the AKM42E: 0.8 x 320 / 1.08 rad/s = 2263 rpm). Would have caught
    the AKM42E's 2400 rpm (+6 %)."""
    akm = [m for m in cat.motors if m.model.startswith("Kollmorgen AKM")]
    assert len(akm) == 3
    for m in akm:
        rule = 0.8 * m.supply_voltage_V / m.back_emf_V_s_rad / RPM_TO_RAD_S
        assert m.rated_speed_rpm == pytest.approx(rule, abs=1.0), m.model
    assert cat.motor("Kollmorgen AKM42E").rated_speed_rpm == pytest.approx(2263, abs=1)


def test_continuous_torque_within_the_stall_torque_at_the_supply(cat):
    """Continuous torque <= Kt U / R (the torque at standstill with the full supply across
    the winding). Would have caught a continuous rating copied from a peak column."""
    for m in cat.motors:
        stall = m.torque_constant_Nm_A * m.supply_voltage_V / m.resistance_ohm
        assert m.stall_torque_Nm <= stall, m.model
        if math.isfinite(m.peak_torque_Nm):
            assert m.stall_torque_Nm <= m.peak_torque_Nm <= stall * 1.0001, m.model


def test_mechanical_time_constant_is_plausible(cat):
    """R J / Kt^2 in :data:`TAU_M_RANGE_S` for every motor. Item 1's RE 40 errors cancel in it
    (0.316 ohm x 134 g cm^2 and 0.299 ohm x 142 g cm^2 both give 4.65 ms: the next tests pin
    them); it catches an inertia exponent slip like the GP22C's 1e4 (the thesis OCR leaves the
    joint-6 rotor's exponent uncertain)."""
    for m in cat.motors:
        tau = m.resistance_ohm * m.rotor_inertia_kg_m2 / m.torque_constant_Nm_A**2
        assert TAU_M_RANGE_S[0] <= tau <= TAU_M_RANGE_S[1], (m.model, tau)


#: lines of the maxon product pages (the entries' sources) that follow from R, J and Kt:
#: mechanical time constant [ms] and stall current [A] at the nominal voltage
MAXON_SHEET = {
    "maxon RE 40 150 W 24 V": (4.67, 80.2),
    "maxon RE 50 200 W 24 V": (3.75, 232.0),
    "maxon RE 65 250 W 48 V (353297)": (3.25, 131.0),
    "maxon EC 45 flat 70 W 48 V": (7.24, 6.97),
    "maxon EC 45 flat 70 W 24 V (397172)": (8.07, 39.5),
    "maxon EC-i 40 70 W 36 V": (0.641, 60.9),
    "maxon EC-i 52 180 W 48 V": (0.58, 167.0),
    "maxon EC 90 flat 260 W 48 V": (7.99, 56.9),
    "maxon EC 90 flat 600 W 30 V (597974)": (7.72, 107.0),
    "maxon EC-4pole 30 200 W 48 V (305015)": (1.69, 124.0),
}


def test_maxon_entries_agree_with_their_sheets_derived_lines(cat):
    """The sheet's mechanical time constant R J / Kt^2 and stall current U / R follow from the
    entry's R, J, Kt and U within the sheet's rounding (1.5 %). Would have caught the RE 40's
    R (U / R = 75.9 A against the sheet's 80.2 A); its J error cancels in R J."""
    for model, (tau_ms, stall_A) in MAXON_SHEET.items():
        m = cat.motor(model)
        R, J, kt = m.resistance_ohm, m.rotor_inertia_kg_m2, m.torque_constant_Nm_A
        assert R * J / kt**2 * 1e3 == pytest.approx(tau_ms, rel=0.015), model
        assert m.supply_voltage_V / R == pytest.approx(stall_A, rel=0.015), model
        assert usable(m) and m.source.startswith("maxon product page of part"), model
    re65 = cat.motor("maxon RE 65 250 W 48 V (353297)")
    assert re65.thermal_time_constant_winding_s == pytest.approx(123.0)


def test_item1_values_corrected(cat):
    """The item-1 values, against maxon's product pages: RE 40 (part 148867, 24 V) R 0.299 ohm
    and J 142 g cm^2; GP 42 C (part 203129) 9.1 g cm^2; the GP 22 C 128:1 (part 143988)
    0.4 g cm^2 at the input, as the thesis' GP22C."""
    re40 = cat.motor("maxon RE 40 150 W 24 V")
    assert re40.resistance_ohm == pytest.approx(0.299, rel=1e-9)
    assert re40.rotor_inertia_kg_m2 == pytest.approx(142e-7, rel=1e-9)
    assert usable(re40)
    assert cat.reducer("maxon GP 42 C 156:1").inertia_kg_m2 == pytest.approx(9.1e-7, rel=1e-9)
    assert cat.reducer("GP22C planetary 128:1").inertia_kg_m2 == pytest.approx(0.4e-7, rel=1e-9)
    assert cat.reducer("maxon GP 22 C 128:1 (143988)").inertia_kg_m2 == pytest.approx(0.4e-7)


def test_one_wave_generator_inertia_per_harmonic_drive_size(cat):
    """CSF and CSG of one size share the wave generator: one input inertia per size, growing
    with the size. Would have caught CSF-20/25 at 1.93e-6 / 4.13e-6 beside CSG-20/25 at
    1.93e-5 / 4.13e-5 kg m^2."""
    by_size: dict[int, set[float]] = {}
    for r in cat.reducers:
        if r.model.startswith("Harmonic Drive"):
            size = int(r.model.split("-")[1])
            by_size.setdefault(size, set()).add(r.inertia_kg_m2)
    assert {20, 25}.issubset(by_size)
    assert all(len(v) == 1 for v in by_size.values()), by_size
    sizes = sorted(by_size)
    values = [next(iter(by_size[s])) for s in sizes]
    assert values == sorted(values)
    assert next(iter(by_size[20])) == pytest.approx(1.93e-5)


def test_catalogue_thesis_parts_are_teachbot6_drives(cat):
    """The parts tagged ``thesis_joints`` carry exactly the numbers of teachbot6's drives file
    (both claim thesis table 4.3). Would have caught the GP22C inertia, 4e-8 in the catalogue
    and 2.44e-12 in drives.toml."""
    drives = read_drives(TEACHBOT6, JOINTS)
    assert set(cat.thesis_parts) == set(JOINTS)
    for joint, (motor, reducer) in cat.thesis_parts.items():
        d = drives[joint]
        for part, mine in ((d.motor, cat.motor(motor)), (d.reducer, cat.reducer(reducer))):
            for f in type(part).__dataclass_fields__:
                a, b = getattr(part, f), getattr(mine, f)
                if isinstance(a, float) and math.isfinite(a):
                    assert b == pytest.approx(a, rel=1e-12), (joint, f)
        assert d.derating == pytest.approx(cat.derating.get(motor, 1.0)), joint


def test_smart_servo_mapping_by_hand(cat):
    """Dynamixel XM430-W350 at 12 V (ROBOTIS e-manual: ratio 353.5, stall 4.1 N m at 2.3 A,
    no load 46 rpm): Ke = 12 / (46 x 353.5 x 2 pi / 60) = 7.047e-3 V s/rad, R = 12 / 2.3 =
    5.217 ohm, gear efficiency 4.1 / (353.5 x Ke x 2.3) = 0.716; the two halves combine only
    with each other."""
    m = cat.motor("Dynamixel XM430-W350 motor")
    r = cat.reducer("Dynamixel XM430-W350 gear")
    ke = 12.0 / (46 * 353.5 * 2 * math.pi / 60)
    assert m.back_emf_V_s_rad == pytest.approx(ke, rel=1e-4)
    assert m.resistance_ohm == pytest.approx(12 / 2.3, rel=1e-4)
    assert r.efficiency == pytest.approx(4.1 / (353.5 * ke * 2.3), rel=1e-3)
    assert r.peak_torque_Nm == 4.1 and r.ratio == 353.5
    # the servo at its stall: motor peak x ratio x efficiency = the sheet's stall torque
    assert m.peak_torque_Nm * r.ratio * r.efficiency == pytest.approx(4.1, rel=1e-3)
    pairs = cat.combinations(allow_estimated=True)
    servo = [(a.model, b.model) for a, b in pairs if a.integrated or b.integrated]
    servos = {p.integrated for p in cat.motors if p.integrated}
    assert len(servos) >= 3 and len(servo) == len(servos)
    assert (m.model, r.model) in servo
    assert not usable(m)  # no continuous rating published: estimated
    assert (m.model, r.model) not in [(a.model, b.model) for a, b in cat.combinations()]


def test_loader_refuses_an_unpaired_servo_and_an_unknown_estimated_field(tmp_path):
    """One line naming the entry: an integrated motor without its gear; an estimated name that
    is no field."""
    motor = (
        '[[motor]]\nmodel = "m"\nstall_torque_Nm = 0.1\nrated_speed_rpm = 1000\ncurrent_A = 1\n'
        "torque_constant_Nm_A = 0.1\nback_emf_V_s_rad = 0.1\nresistance_ohm = 1\n"
        "inductance_H = 0.001\nrotor_inertia_kg_m2 = 1e-6\nsupply_voltage_V = 24\n"
        'mass_kg = 1\nprice = 1\nsource = "s"\n'
    )
    reducer = (
        '[[reducer]]\nmodel = "r"\nratio = 10\nefficiency = 0.9\nrated_torque_Nm = 1\n'
        'peak_torque_Nm = 2\nmax_input_speed_rpm = 5000\nmass_kg = 1\nprice = 1\nsource = "s"\n'
    )
    bad = tmp_path / "a.toml"
    bad.write_text(motor + 'integrated = "S"\n' + reducer)
    with pytest.raises(RobotDescriptionError, match="integrated 'S' needs exactly one reducer"):
        load_catalogue(bad)
    bad.write_text(motor + 'estimated = ["colour"]\n' + reducer)
    with pytest.raises(RobotDescriptionError, match=r"estimated: unknown field\(s\) \['colour'\]"):
        load_catalogue(bad)
    ok = tmp_path / "b.toml"
    ok.write_text(motor + 'estimated = ["rotor_inertia_kg_m2"]\n' + reducer)
    c = load_catalogue(ok)
    assert c.combinations() == [] and len(c.combinations(allow_estimated=True)) == 1


def test_the_catalogue_page_is_generated_from_the_toml(cat):
    """docs/catalogue.md is :func:`catalogue_markdown` of the shipped catalogue (rewrite it
    with ``python -m armlab.robot.catalogue_doc docs/catalogue.md``); every entry is on it."""
    text = (REPO / "docs" / "catalogue.md").read_text(encoding="utf-8")
    assert text == catalogue_markdown(cat)
    for p in (*cat.motors, *cat.reducers):
        assert f"| {p.model} |" in text
