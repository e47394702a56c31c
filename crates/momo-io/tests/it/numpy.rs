//! matches.csv as numpy's `savetxt` writes it with a header and its default number format
//! (`# frame,...` header, every number as `%.18e`, so frames and cameras as whole floats), and
//! a precise error for its default space delimiter.
#![allow(clippy::unwrap_used)] // tests may unwrap

use momo_io::*;

const RIG: &str = r#"{"cameras": [{"model": {"type": "pinhole", "fx": 718.856, "fy": 718.856,
  "cx": 607.1928, "cy": 185.2157, "width": 1241, "height": 376},
  "T_vehicle_camera": [[0, 0, 1, 1.0], [-1, 0, 0, 0.0], [0, -1, 0, 1.65], [0, 0, 0, 1]]}]}"#;

#[test]
fn numpy_savetxt_default_output_is_read() {
    let rig = read_rig_from_str(RIG, "rig.json").unwrap();
    // np.savetxt("matches.csv", a, delimiter=",", header="frame,camera,u0,v0,u1,v1"), bytes
    // as numpy 1.x/2.x print them.
    let numpy = "# frame,camera,u0,v0,u1,v1\n\
        1.000000000000000000e+00,0.000000000000000000e+00,6.123099999999999454e+02,2.017700000000000102e+02,6.150199999999999818e+02,2.034000000000000057e+02\n\
        2.000000000000000000e+00,0.000000000000000000e+00,6.000000000000000000e+02,2.000000000000000000e+02,6.010000000000000000e+02,2.010000000000000000e+02\n";
    let plain = "frame,camera,u0,v0,u1,v1\n1,0,612.31,201.77,615.02,203.40\n2,0,600,200,601,201\n";
    let read = |text: &str| -> Vec<_> {
        MatchReader::new(text.as_bytes(), &rig, "matches.csv")
            .unwrap()
            .map(|r| r.unwrap())
            .collect()
    };
    assert_eq!(read(numpy), read(plain));
    assert_eq!(read(numpy).len(), 2);

    // A frame that is not whole, and numpy's default space delimiter: precise errors.
    let half = "# frame,camera,u0,v0,u1,v1\n1.5,0,1,2,3,4\n";
    let e = MatchReader::new(half.as_bytes(), &rig, "m.csv")
        .unwrap()
        .next()
        .unwrap()
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.csv:2: `frame`: cannot parse `1.5`"), "{e}");
    let spaces = "# frame camera u0 v0 u1 v1\n1 0 1 2 3 4\n";
    let e = MatchReader::new(spaces.as_bytes(), &rig, "m.csv")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.starts_with("m.csv:1: bad header: columns must be separated by commas")
            && e.contains("delimiter=\",\""),
        "{e}"
    );
}
