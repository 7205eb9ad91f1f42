//! The malformed `.pmesh` corpus in `tests/data/bad_pmesh/`: each file is a clean
//! `Format` error naming the file and a byte offset; the good file decodes.

mod common;

use meshlod::lod::{read_pmesh, PmError};

#[test]
fn bad_pmesh_files_are_named_errors() {
    let dir = common::data_dir().join("bad_pmesh");
    let good = read_pmesh(dir.join("good_icosahedron.pmesh")).expect("good file");
    assert!(good.complete);
    assert!(good.pm.split_count() > 0);
    let cases = [
        ("truncated_in_split.pmesh", "unexpected end"),
        ("truncated_in_base.pmesh", "needs at least"),
        ("bad_magic.pmesh", "not a .pmesh"),
        ("huge_point_count.pmesh", "needs at least"),
        ("future_version.pmesh", "unsupported version 7"),
        ("trailing_bytes.pmesh", "trailing bytes"),
    ];
    for (name, want) in cases {
        match read_pmesh(dir.join(name)) {
            Err(e @ PmError::Format { .. }) => {
                let msg = e.to_string();
                assert!(
                    msg.contains(name) && msg.contains("byte ") && msg.contains(want),
                    "{name}: {msg}"
                );
            }
            Err(e) => panic!("{name}: unexpected error kind: {e}"),
            Ok(_) => panic!("{name}: accepted"),
        }
    }
    assert!(matches!(
        read_pmesh(dir.join("does_not_exist.pmesh")),
        Err(PmError::Io { .. })
    ));
}
