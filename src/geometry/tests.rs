//! The geometry's tests.

use super::*;

const PRISM: &str = r#"
name = "prism"
[[mic]]
position = [0.25, 0.20, 0.18]
[[mic]]
position = [0.25, -0.20, 0.18]
[[mic]]
position = [-0.25, 0.20, 0.18]
[[mic]]
position = [-0.25, -0.20, 0.18]
[[mic]]
position = [0.25, 0.20, -0.18]
[[mic]]
position = [0.25, -0.20, -0.18]
[[mic]]
position = [-0.25, 0.20, -0.18]
[[mic]]
position = [-0.25, -0.20, -0.18]
"#;

#[test]
fn prism_is_3d_with_expected_aperture() {
    let g = Geometry::from_toml_str(PRISM).unwrap();
    assert_eq!(g.mics.len(), 8);
    assert_eq!(g.shape, Shape::Volumetric);
    let (a, _, _) = g.aperture();
    assert!((a - (0.5f64.powi(2) + 0.4f64.powi(2) + 0.36f64.powi(2)).sqrt()).abs() < 1e-12);
    assert!(g.centre.norm() < 1e-12);
    assert_eq!(g.speed_of_sound, 343.0);
    assert!(g.warnings.is_empty());
}

#[test]
fn planar_default_side_is_up_or_forward() {
    let g = Geometry::from_positions(&[
        [0.1, 0.0, 0.0],
        [0.0, 0.1, 0.0],
        [-0.1, 0.0, 0.0],
        [0.0, -0.1, 0.0],
    ])
    .unwrap();
    match g.shape {
        Shape::Planar { normal } => assert!((normal - Vector3::z()).norm() < 1e-9),
        s => panic!("{s:?}"),
    }
    // A vertical plane containing the z axis (the y-z plane): default side +x.
    let g = Geometry::from_positions(&[
        [0.0, 0.1, 0.0],
        [0.0, 0.0, 0.1],
        [0.0, -0.1, 0.0],
        [0.0, 0.0, -0.1],
    ])
    .unwrap();
    match g.shape {
        Shape::Planar { normal } => assert!((normal - Vector3::x()).norm() < 1e-9),
        s => panic!("{s:?}"),
    }
}

#[test]
fn linear_arrays_are_recognised() {
    let g =
        Geometry::from_positions(&[[0.0, 0.0, 0.0], [0.05, 0.0, 0.0], [0.1, 0.0, 0.0]]).unwrap();
    match g.shape {
        Shape::Linear { axis } => assert!((axis.x.abs() - 1.0).abs() < 1e-9),
        s => panic!("{s:?}"),
    }
    assert_eq!(g.side, Vector3::y());
    let g = Geometry::from_positions(&[[0.0, 0.0, 0.0], [0.0, 0.1, 0.0]]).unwrap();
    assert!(matches!(g.shape, Shape::Linear { .. }));
    assert_eq!(g.side, Vector3::x());
}

#[test]
fn bad_geometries_are_rejected_with_reasons() {
    let cases: &[(&str, &str)] = &[
        ("[[mic]]\nposition = [0,0,0]\n", "at least 2"),
        ("[[mic]]\nposition = [0.0,0,0]\n[[mic]]\nposition = [0.0,0,0]\n", "same position"),
        ("[[mic]]\nposition = [nan,0,0]\n[[mic]]\nposition = [1.0,0,0]\n", "non-finite"),
        ("bogus = 1\n[[mic]]\nposition = [0.0,0,0]\n[[mic]]\nposition = [1.0,0,0]\n", "unknown field"),
        ("[[mic]]\nposition = [0.0,0,0]\ngain = 2\n[[mic]]\nposition = [1.0,0,0]\n", "unknown field"),
        ("speed_of_sound = -3\n[[mic]]\nposition = [0.0,0,0]\n[[mic]]\nposition = [1.0,0,0]\n", "speed_of_sound"),
        ("[[mic]]\nposition = [0.0,0,0]\nchannel = 1\n[[mic]]\nposition = [1.0,0,0]\n", "give it to all"),
        ("[[mic]]\nposition = [0.0,0,0]\nchannel = 1\n[[mic]]\nposition = [1.0,0,0]\nchannel = 1\n", "both use channel 1"),
        ("[[mic]]\nposition = [0.0,0]\n[[mic]]\nposition = [1.0,0,0]\n", "invalid geometry TOML"),
        ("side = [1.0, 0, 0]\n[[mic]]\nposition = [0.0,0,0]\n[[mic]]\nposition = [1.0,0,0]\n", "parallel"),
        ("side = [1.0, 0, 0]\n[[mic]]\nposition = [0.0,0,0]\n[[mic]]\nposition = [1.0,0,0]\n[[mic]]\nposition = [0.0,1,0]\n", "lies in the plane"),
        ("side = [0.0, 0, 0]\n[[mic]]\nposition = [0.0,0,0]\n[[mic]]\nposition = [1.0,0,0]\n", "non-zero"),
    ];
    for (text, needle) in cases {
        let err = format!("{:#}", Geometry::from_toml_str(text).unwrap_err());
        assert!(err.contains(needle), "{text:?}: {err}");
        assert!(!err.contains('\n'), "one line: {err}");
    }
}

#[test]
fn millimetres_as_metres_and_absurd_sizes_are_errors() {
    for scale in [1000.0, 1e150] {
        let p = |x: f64, y: f64, z: f64| [x * scale, y * scale, z * scale];
        let err = Geometry::from_positions(&[
            p(0.25, 0.2, 0.18),
            p(-0.25, 0.2, 0.18),
            p(0.0, -0.2, 0.0),
            p(0.0, 0.0, -0.18),
        ])
        .unwrap_err()
        .to_string();
        if scale == 1000.0 {
            assert!(err.contains("up to 504.876 m apart"), "{err}");
            assert!(err.contains("they look like millimetres (divide them by 1000: the array is then 50.5 cm across)"), "{err}");
        } else {
            assert!(!err.contains("look like"), "{err}");
        }
        assert!(!err.contains("e0 m") && !err.contains("e2 m"), "{err}");
    }
}

/// A 3 cm square written in centimetres is a valid 4.24 m array, but the warning says
/// which unit it likely is and by what to divide.
#[test]
fn a_centimetre_geometry_is_warned_about() {
    let g = Geometry::from_positions(&[
        [1.5, 1.5, 0.0],
        [-1.5, 1.5, 0.0],
        [-1.5, -1.5, 0.0],
        [1.5, -1.5, 0.0],
    ])
    .unwrap();
    assert_eq!(g.warnings.len(), 1, "{:?}", g.warnings);
    assert!(
        g.warnings[0].contains("4.243 m apart")
            && g.warnings[0]
                .contains("centimetres (divide them by 100: the array is then 4.2 cm across)"),
        "{:?}",
        g.warnings
    );
    let metres = Geometry::from_positions(&[
        [0.015, 0.015, 0.0],
        [-0.015, 0.015, 0.0],
        [0.0, -0.015, 0.0],
    ])
    .unwrap();
    assert!(metres.warnings.is_empty());
}

/// Against the closed forms: a pair `d` apart moves by `c / (fs d)` radians; for
/// microphones centred on the origin `D^T D = n sum(m m^T)`, which is `16 a^2 I`
/// for a regular tetrahedron on the corners `(+-a, +-a, +-a)` and `4 s^2` in the
/// plane of a square of side `s`.
#[test]
fn direction_spread_follows_the_closed_forms() {
    let (c, fs) = (343.0, 16000.0);
    let check = |positions: &[[f64; 3]], radians: f64| {
        let g = Geometry::from_positions(positions).unwrap();
        let got = g.direction_spread_deg(fs, c);
        assert!((got - radians.to_degrees()).abs() < 1e-9, "{got}");
    };
    check(&[[-0.05, 0.0, 0.0], [0.05, 0.0, 0.0]], c / fs / 0.1);
    let a = 0.022981;
    check(
        &[[a, a, a], [a, -a, -a], [-a, a, -a], [-a, -a, a]],
        c / fs / (4.0 * a),
    );
    let h = 0.0457 / 2.0;
    check(
        &[[h, h, 0.0], [-h, h, 0.0], [-h, -h, 0.0], [h, -h, 0.0]],
        c / fs / (2.0 * 0.0457),
    );
    // The tetrahedron at 16 kHz: 13.4 deg a sample (0.6 of one: 8 deg).
    let g = Geometry::from_positions(&[[a, a, a], [a, -a, -a], [-a, a, -a], [-a, -a, a]]);
    assert!((g.unwrap().direction_spread_deg(fs, c) - 13.36).abs() < 0.01);
}

#[test]
fn explicit_channels_are_kept() {
    let g = Geometry::from_toml_str(
        "[[mic]]\nposition=[0.0,0,0]\nchannel=3\n[[mic]]\nposition=[0.1,0,0]\nchannel=0\n",
    )
    .unwrap();
    assert!(g.explicit_channels);
    assert_eq!(g.mics[0].channel, 3);
    assert_eq!(g.mics[1].channel, 0);
}

#[test]
fn an_oriented_planar_array_keeps_its_side_in_its_own_frame() {
    // A horizontal square hung on a wall: pitched up 90 deg, its x axis points up and its
    // normal (+z in its frame, the default side) points backward (-x in the room).
    let square = "[orientation]\npitch_deg = 90\n[[mic]]\nposition = [0.05, 0, 0]\n[[mic]]\nposition = [0, 0.05, 0]\n[[mic]]\nposition = [-0.05, 0, 0]\n[[mic]]\nposition = [0, -0.05, 0]\n";
    let g = Geometry::from_toml_str(square).unwrap();
    let close = |a: Vector3<f64>, b: Vector3<f64>| (a - b).norm() < 1e-12;
    let Shape::Planar { normal } = g.shape else {
        panic!("{:?}", g.shape)
    };
    assert!(close(normal, -Vector3::x()), "{normal:?}");
    assert!(close(g.side, -Vector3::x()));
    assert!(close(g.mics[0].position, Vector3::new(0.0, 0.0, 0.05)));
    assert!(close(g.array_position(0), Vector3::new(0.05, 0.0, 0.0)));
    // Three of its microphones are still that plane, on the same side.
    assert_eq!(g.subset_shape(0b0111).unwrap(), g.shape);
    // Two of them: a line, whose reporting plane holds the default side turned with it
    // (the array's +x is now up: +z).
    let Shape::Linear { axis } = g.subset_shape(0b0101).unwrap() else {
        panic!()
    };
    assert!(axis.x.abs() < 1e-12 && axis.y.abs() < 1e-12, "{axis:?}");
}
