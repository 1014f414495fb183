//! Machine files (DESIGN.md section 4): the bundled examples load, every shaft's exact ratio, every stage's
//! mesh order and the planetary fault orders equal values derived by hand from the teeth (Willis equation),
//! ratios that do not close and teeth that do not fit are refused, and every wrong field is named with its
//! path.

use gearvib::model::kinematics::{Machine, Member, Ratio, Stage};
use gearvib::scene::SceneError;
use gearvib::scene::machine::{load_machine, machine_from_str};
use serde_json::{Value, json};

fn r(num: i128, den: i128) -> Ratio {
    Ratio::new(num, den).unwrap()
}

fn bundled(name: &str) -> Machine {
    load_machine(&format!("{}/data/machines/{name}", env!("CARGO_MANIFEST_DIR"))).unwrap()
}

#[test]
fn the_paper_pair_has_the_papers_orders() {
    let m = bundled("paper-single-pair-z14z39.json");
    // 1800 rpm pinion: wheel 30 * 14 / 39 Hz, mesh 420 Hz (DESIGN.md section 2)
    assert_eq!(m.order(1), r(-14, 39));
    assert_eq!(m.mesh_order(0), Some(r(14, 1)));
    let speeds = m.speeds_hz(0, 30.0);
    assert!((speeds[1] - 30.0 * 14.0 / 39.0).abs() < 1e-12);
    assert!((m.mesh_hz(30.0)[0] - 420.0).abs() < 1e-12);
    // gcd(14, 39) = 1: a tooth pair meets again after 39 pinion revolutions, f_ht = f_m / (14 39)
    assert_eq!(m.hunting_order(0), Some(r(1, 39)));
}

#[test]
fn the_two_stage_box_has_the_hand_derived_ratios() {
    let m = bundled("two-stage-z23z61-z19z47.json");
    assert_eq!(m.reference(), 0);
    // f_int = f_in 23/61 (sense reversed); f_out = f_in (23/61)(19/47) = 437/2867 (sense restored)
    assert_eq!(m.order(1), r(-23, 61));
    assert_eq!(m.order(2), r(437, 2867));
    // mesh 1 = 23 f_in = 61 f_int; mesh 2 = 19 f_int = 47 f_out = 437/61 f_in
    assert_eq!(m.mesh_order(0), Some(r(23, 1)));
    assert_eq!(m.mesh_order(1), Some(r(437, 61)));
    assert_eq!(m.mesh_order(1).unwrap(), m.order(2).abs().checked_mul(r(47, 1)).unwrap());
    // the speed of any shaft gives the others: output at 1 Hz means input at 2867/437 Hz
    let s = m.speeds_hz(2, 1.0);
    assert!((s[0] - 2867.0 / 437.0).abs() < 1e-12 && (s[1] - 47.0 / 19.0).abs() < 1e-12);
    let tach = m.tachometer.as_ref().unwrap();
    assert_eq!((tach.channel, tach.shaft, tach.pulses_per_rev), (2, 0, 1));
    assert_eq!(m.sensors.len(), 1);
}

/// z_s w_s + z_r w_r = (z_s + z_r) w_c, checked in exact arithmetic on the orders the machine derived.
fn assert_willis(m: &Machine, k: usize) {
    let Stage::Planetary(p) = &m.stages[k] else { panic!("planetary stage expected") };
    let o = m.planetary_orders(k).unwrap();
    let zs = r(p.sun_teeth as i128, 1);
    let zr = r(p.ring_teeth as i128, 1);
    let lhs = zs.checked_mul(o.sun).unwrap().checked_add(zr.checked_mul(o.ring).unwrap()).unwrap();
    let rhs = zs.checked_add(zr).unwrap().checked_mul(o.carrier).unwrap();
    assert_eq!(lhs, rhs, "Willis equation");
    // the mesh seen from the ring and from the planet equals the one from the sun
    assert_eq!(o.mesh, zr.checked_mul(o.ring.checked_sub(o.carrier).unwrap()).unwrap().abs());
    let zp = r(p.planet_teeth as i128, 1);
    assert_eq!(o.mesh, zp.checked_mul(o.planet.checked_sub(o.carrier).unwrap()).unwrap().abs());
}

#[test]
fn the_planetary_box_has_the_closed_form_orders() {
    let m = bundled("planetary-z21z31z83-then-parallel-z29z71.json");
    let o = m.planetary_orders(0).unwrap();
    // ring fixed, sun input (z_s 21, z_p 31, z_r 83, N_p 3), by hand (gearboxes.md section 2):
    // f_c = f_s 21/104; f_m = z_r f_c = 1743/104; f_pp = 3 f_c = 63/104
    assert_eq!(o.carrier, r(21, 104));
    assert_eq!(o.mesh, r(1743, 104));
    assert_eq!(o.planet_pass, r(63, 104));
    // sun fault N_p (f_s - f_c) = 3 x 83/104; ring fault N_p f_c = 63/104 = f_pp
    assert_eq!(o.sun_fault, r(249, 104));
    assert_eq!(o.ring_fault, r(63, 104));
    // planet: f_p/c = -f_c z_r / z_p = -1743/3224; absolute f_c (1 - z_r / z_p) = -273/806;
    // fault f_m / z_p one flank, 2 f_m / z_p both
    assert_eq!(o.planet_relative, r(-1743, 3224));
    assert_eq!(o.planet, r(-273, 806));
    assert_eq!(o.planet_fault, r(1743, 3224));
    assert_eq!(o.planet_fault_both, r(1743, 1612));
    // output stage 29/71 on the carrier: output = -(21/104)(29/71), mesh 29 x 21/104
    assert_eq!(m.order(2), r(-609, 7384));
    assert_eq!(m.mesh_order(1), Some(r(609, 104)));
    assert_willis(&m, 0);
    let Stage::Planetary(p) = &m.stages[0] else { panic!() };
    assert_eq!(p.planet_angles_deg.len(), 3);
    assert_eq!((p.sun, p.carrier, p.ring), (Member::Shaft(0), Member::Shaft(1), Member::Fixed));
}

fn planetary(sun: &str, carrier: &str, ring: &str) -> Value {
    json!({
        "machine": "variant", "shafts": ["a", "b"],
        "stages": [{"kind": "planetary", "sun": sun, "carrier": carrier, "ring": ring, "planets": 4,
                    "teeth": {"sun": 20, "planet": 30, "ring": 80}}]
    })
}

#[test]
fn every_fixed_member_follows_the_willis_equation() {
    // sun fixed, ring (reference) drives the carrier: w_c = w_r z_r / (z_s + z_r) = 80/100
    let m = machine_from_str(&planetary("fixed", "b", "a").to_string(), "x.json").unwrap();
    let o = m.planetary_orders(0).unwrap();
    assert_eq!(o.carrier, r(4, 5));
    assert_eq!(o.mesh, r(16, 1)); // z_s |0 - 4/5| = 16
    assert_eq!(o.ring_fault, r(4, 5)); // N_p |1 - 4/5| = 4/5
    assert_eq!(o.sun_fault, r(16, 5)); // N_p |0 - 4/5|
    assert_willis(&m, 0);
    // carrier fixed (a star stage): w_r = -w_s z_s / z_r = -1/4, mesh z_s w_s = 20, no planet pass
    let m = machine_from_str(&planetary("a", "fixed", "b").to_string(), "x.json").unwrap();
    let o = m.planetary_orders(0).unwrap();
    assert_eq!(o.ring, r(-1, 4));
    assert_eq!(o.mesh, r(20, 1));
    assert_eq!(o.planet_pass, Ratio::ZERO);
    assert_eq!(o.planet_relative, r(-2, 3)); // -(20/30) (1 - 0)
    assert_willis(&m, 0);
    // equal spacing: (20 + 80) / 4 whole, so the angles default to 0, 90, 180, 270
    let Stage::Planetary(p) = &m.stages[0] else { panic!() };
    assert_eq!(p.planet_angles_deg, vec![0.0, 90.0, 180.0, 270.0]);
}

#[test]
fn ratios_that_close_around_a_loop_are_accepted() {
    // two layshafts' worth of the same ratio between the same shafts (23/61 = 46/122)
    let mut v: Value = serde_json::from_str(&two_stage()).unwrap();
    v["stages"]
        .as_array_mut()
        .unwrap()
        .push(json!({"kind": "parallel", "driving": "input", "driven": "intermediate", "teeth": [46, 122]}));
    let m = machine_from_str(&v.to_string(), "x.json").unwrap();
    assert_eq!(m.order(1), r(-23, 61));
}

fn two_stage() -> String {
    std::fs::read_to_string(format!("{}/data/machines/two-stage-z23z61-z19z47.json", env!("CARGO_MANIFEST_DIR")))
        .unwrap()
}

fn planetary_box() -> String {
    std::fs::read_to_string(format!(
        "{}/data/machines/planetary-z21z31z83-then-parallel-z29z71.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// Applies `edit` to the machine `base`, loads it, and checks the error names `field` (and says `what`).
fn refused(base: &str, edit: impl Fn(&mut Value), field: &str, what: &str) {
    let mut v: Value = serde_json::from_str(base).unwrap();
    edit(&mut v);
    let e = machine_from_str(&v.to_string(), "box.json").expect_err(field);
    let msg = e.to_string();
    let named = match &e {
        SceneError::Invalid { field: f, .. } => f == field,
        _ => msg.contains(&format!("`{field}`")),
    };
    assert!(named, "expected field `{field}` in: {msg}");
    assert!(msg.contains(what), "expected '{what}' in: {msg}");
    assert!(msg.starts_with("box.json: "), "file named: {msg}");
}

#[test]
fn every_wrong_field_is_named_with_its_path() {
    let two = two_stage();
    let pl = planetary_box();
    refused(&two, |v| v["colour"] = json!("red"), "colour", "unknown field");
    refused(&two, |v| v["stages"][1]["teeth"] = json!("many"), "stages[1].teeth", "invalid type");
    refused(&two, |v| v["stages"][1]["teeth"] = json!([19]), "stages[1].teeth", "length");
    refused(&two, |v| v["stages"][0]["teeth"][1] = json!(-3), "stages[0].teeth[1]", "invalid value");
    refused(&two, |v| v["stages"][0]["teeth"][1] = json!(0), "stages[0].teeth[1]", "3..=10000");
    refused(&two, |v| v["stages"][0]["kind"] = json!("bevel"), "stages[0].kind", "unknown variant");
    refused(&two, |v| v["stages"][0]["speed"] = json!(1), "stages[0].speed", "unknown field");
    refused(&two, |v| v["stages"][0]["driven"] = json!("outptu"), "stages[0].driven", "not one of the shafts");
    refused(&two, |v| v["stages"][0]["driven"] = json!("input"), "stages[0].driven", "driving shaft");
    refused(&two, |v| v["stages"][0]["sun"] = json!("input"), "stages[0].sun", "not a field of a parallel stage");
    refused(
        &two,
        |v| v["stages"][1].as_object_mut().unwrap().remove("driving").map(|_| ()).unwrap(),
        "stages[1].driving",
        "missing",
    );
    refused(&two, |v| v["shafts"][1] = json!("input"), "shafts[1]", "named twice");
    refused(&two, |v| v["shafts"].as_array_mut().unwrap().push(json!("spare")), "shafts[3]", "not connected");
    refused(
        &two,
        |v| {
            v["stages"]
                .as_array_mut()
                .unwrap()
                .push(json!({"kind": "parallel", "driving": "input", "driven": "intermediate", "teeth": [23, 60]}))
        },
        "stages[2]",
        "do not close",
    );
    refused(&two, |v| v["speed"]["shaft"] = json!("motor"), "speed.shaft", "not one of the shafts");
    refused(&two, |v| v["speed"]["nominal_rpm"] = json!(-5), "speed.nominal_rpm", "positive");
    refused(&two, |v| v["speed"]["tolerance"] = json!(2), "speed.tolerance", "[0, 1)");
    refused(&two, |v| v["speed"]["rpm"] = json!(2), "speed.rpm", "unknown field");
    refused(&two, |v| v["tachometer"]["pulses_per_rev"] = json!(0), "tachometer.pulses_per_rev", "1..=100000");
    refused(&two, |v| v["tachometer"]["channel"] = json!(0), "tachometer.channel", "1-based");
    refused(&two, |v| v["sensors"][0]["unit"] = json!("furlong"), "sensors[0].unit", "unknown variant");
    refused(&two, |v| v["sensors"][0]["sensitivity"] = json!(0), "sensors[0].sensitivity", "positive");
    refused(&two, |v| v["sensors"][0]["channel"] = json!(2), "sensors[0].channel", "tachometer");
    refused(&two, |v| v["sensors"][0]["position"] = json!(3), "sensors[0].position", "invalid type");
    // planetary fields
    refused(&pl, |v| v["stages"][0]["teeth"]["ring"] = json!(84), "stages[0].teeth.ring", "do not fit");
    refused(&pl, |v| v["stages"][0]["teeth"]["moon"] = json!(4), "stages[0].teeth.moon", "unknown field");
    refused(&pl, |v| v["stages"][0]["teeth"] = json!([21, 83]), "stages[0].teeth", "PlanetaryTeeth");
    refused(&pl, |v| v["stages"][0]["teeth"]["planet"] = json!(2), "stages[0].teeth.planet", "3..=10000");
    refused(&pl, |v| v["stages"][0]["ring"] = json!("output"), "stages[0].ring", "exactly one");
    refused(&pl, |v| v["stages"][0]["carrier"] = json!("fixed"), "stages[0].carrier", "exactly one");
    refused(&pl, |v| v["stages"][0]["carrier"] = json!("input"), "stages[0].carrier", "same shaft");
    refused(&pl, |v| v["stages"][0]["driving"] = json!("input"), "stages[0].driving", "not a field of a planetary");
    refused(&pl, |v| v["stages"][0]["planets"] = json!(0), "stages[0].planets", "1..=32");
    refused(
        &pl,
        |v| v["stages"][0].as_object_mut().unwrap().remove("planet_angles_deg").map(|_| ()).unwrap(),
        "stages[0].planet_angles_deg",
        "not whole",
    );
    // 120 degrees is 104/3 pitches: planet 2 could not mesh with sun and ring at once
    refused(
        &pl,
        |v| v["stages"][0]["planet_angles_deg"][1] = json!(120),
        "stages[0].planet_angles_deg[1]",
        "cannot be assembled",
    );
    refused(&pl, |v| v["stages"][0]["planet_angles_deg"][0] = json!(10), "stages[0].planet_angles_deg[0]", "must be 0");
    refused(
        &pl,
        |v| v["stages"][0]["planet_angles_deg"] = json!([0, 34.0 * 360.0 / 104.0]),
        "stages[0].planet_angles_deg",
        "one per planet",
    );
}

#[test]
fn a_machine_file_that_is_not_json_is_refused_with_its_name() {
    let e = machine_from_str("{\"machine\": \"x\",", "broken.json").unwrap_err();
    assert!(e.to_string().starts_with("broken.json: "), "{e}");
    let e = load_machine("/nonexistent/box.json").unwrap_err();
    assert!(e.to_string().contains("/nonexistent/box.json"), "{e}");
}

#[test]
fn labelled_lines_name_the_shaft_of_every_sideband_family() {
    use gearvib::model::kinematics::LineKind;
    let m = bundled("two-stage-z23z61-z19z47.json");
    let lines = m.labelled_lines(2, 2);
    // per stage and harmonic: the mesh line and 2 shafts x 2 sides x 2 sidebands
    assert_eq!(lines.len(), 2 * 2 * (1 + 2 * 2 * 2));
    let find = |label: &str| lines.iter().find(|l| l.label == label).unwrap_or_else(|| panic!("{label}")).order;
    // the intermediate shaft (23/61 of the input) spaces a family around both of its meshes:
    // 23 - 23/61 = 1380/61 around mesh 1, 2 x 437/61 + 2 x 23/61 = 920/61 around mesh 2's second harmonic
    assert_eq!(find("stage 1 mesh x1 - 1 x intermediate"), r(1380, 61));
    assert_eq!(find("stage 2 mesh x2 + 2 x intermediate"), r(920, 61));
    // the output shaft (437/2867) around mesh 2: 437/61 + 437/2867 = 437 x 48 / 2867
    assert_eq!(find("stage 2 mesh x1 + 1 x output"), r(437 * 48, 2867));
    assert_eq!(find("stage 1 mesh x2"), r(46, 1));
    let side = lines.iter().find(|l| l.label == "stage 1 mesh x1 + 2 x input").unwrap();
    assert_eq!(side.kind, LineKind::ShaftSideband { harmonic: 1, n: 2, shaft: 0 });
    assert_eq!(side.order, r(25, 1));
    // planetary: planet-pass families around the mesh, 1743/104 +- 63/104
    let p = bundled("planetary-z21z31z83-then-parallel-z29z71.json");
    let lines = p.labelled_lines(1, 1);
    let find = |label: &str| lines.iter().find(|l| l.label == label).unwrap_or_else(|| panic!("{label}")).order;
    assert_eq!(find("stage 1 mesh x1 - 1 x planet pass"), r(1680, 104));
    assert_eq!(find("stage 1 mesh x1 + 1 x carrier"), r(1764, 104));
}
