//! `[orientation]` in the geometry: directions come out in the room frame, the array's
//! directions turned by its pose, whether the pose is given as angles or as a matrix.

use crate::support;

use nalgebra::Vector3;
use ssl::geometry::unit_from_angles;
use support::*;

/// The median direction of a run's rows.
fn median_direction(geometry: &std::path::Path, wav: &std::path::Path) -> (Vector3<f64>, String) {
    let out = run(&["analyze", s(wav), "-g", s(geometry), "--no-track"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = String::from_utf8(out.stdout).unwrap();
    let rows = parse_csv(&text);
    assert!(rows.len() > 30, "{} rows", rows.len());
    let median = |f: &dyn Fn(&Row) -> f64| {
        let mut v: Vec<f64> = rows.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let u = Vector3::new(median(&|r| r.u.x), median(&|r| r.u.y), median(&|r| r.u.z));
    (u.normalize(), text)
}

#[test]
fn directions_come_out_in_the_room_frame() {
    // A source at azimuth 30, elevation 10 in the array frame.
    let (dir, wav, _) = recording(0.8);
    let truth = unit_from_angles(30.0, 10.0);
    let geometry = |name: &str, table: &str| {
        write(
            dir.path(),
            name,
            geometry_toml(&prism(), &format!("[orientation]\n{table}")),
        )
    };
    let err = |got: &Vector3<f64>, want: &Vector3<f64>| got.angle(want).to_degrees();
    // Turned 90 deg to the left: the source is at azimuth 120.
    let yaw = geometry("yaw.toml", "yaw_deg = 90");
    let (u, yaw_rows) = median_direction(&yaw, &wav);
    let want = unit_from_angles(120.0, 10.0);
    assert!(err(&u, &want) < 1.5, "{u:?}");
    // The same pose as a matrix (column j: the array's axis j in the room): the same
    // rows, byte for byte.
    let matrix = geometry("matrix.toml", "matrix = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]");
    assert_eq!(median_direction(&matrix, &wav).1, yaw_rows);
    // Rolled 90 deg (the left side up): (x, y, z) in the array is (x, -z, y) in the room.
    let roll = geometry("roll.toml", "roll_deg = 90");
    let want = Vector3::new(truth.x, -truth.z, truth.y);
    let (u, _) = median_direction(&roll, &wav);
    assert!(err(&u, &want) < 1.5, "{u:?} vs {want:?}");
    // Pitched up 20 deg: a source ahead and 10 deg up is 30 deg up, its azimuth kept.
    let pitch = geometry("pitch.toml", "pitch_deg = 20");
    let (u, _) = median_direction(&pitch, &wav);
    let el = u.z.asin().to_degrees();
    let az = u.y.atan2(u.x).to_degrees();
    // Pitch turns the array's x-z plane: the source (not in it) moves up by less than
    // 20 deg; the exact answer rotates its vector.
    let p = 20f64.to_radians();
    let want = Vector3::new(
        truth.x * p.cos() - truth.z * p.sin(),
        truth.y,
        truth.x * p.sin() + truth.z * p.cos(),
    );
    assert!(err(&u, &want) < 1.5, "az {az} el {el} vs {want:?}");
    assert!(el > 25.0, "{el}");
    // The JSON metadata keeps the file's positions and records the rotation.
    let out = run(&[
        "analyze",
        s(&wav),
        "-g",
        s(&yaw),
        "--no-track",
        "--format",
        "json",
    ]);
    let doc: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let g = &doc["geometry"];
    assert_eq!(g["orientation"][0][1], serde_json::json!(-1.0));
    let first = prism()[0];
    assert_eq!(
        g["mics"][0]["position"],
        serde_json::json!([first.x, first.y, first.z])
    );
}

#[test]
fn a_bad_orientation_is_one_clear_error() {
    let dir = tempdir();
    for (table, says) in [
        (
            "yaw_deg = 10\nmatrix = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]",
            "both",
        ),
        ("matrix = [[1, 0, 0], [0, -1, 0], [0, 0, 1]]", "mirror"),
        ("matrix = [[1, 0, 0], [0, 1, 0]]", "3 rows"),
        ("yaw = 10", "unknown field"),
        ("", "empty"),
    ] {
        let g = write(
            dir.path(),
            "g.toml",
            geometry_toml(&prism(), &format!("[orientation]\n{table}")),
        );
        let out = run(&["geometry", s(&g)]);
        assert_eq!(out.status.code(), Some(1), "{table}");
        let e = stderr(&out);
        assert!(e.contains("g.toml") && e.contains(says), "{table}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "{e}");
    }
}

#[test]
fn an_orientation_given_as_a_list_is_refused_not_read_as_angles() {
    let dir = tempdir();
    let g = write(
        dir.path(),
        "g.toml",
        format!("orientation = [1, 2, 3]\n{}", geometry_toml(&prism(), "")),
    );
    let o = run(&["geometry", s(&g)]);
    assert_ne!(o.status.code(), Some(0));
    assert!(
        stderr(&o).contains("expected a table [orientation]"),
        "{}",
        stderr(&o)
    );
}
