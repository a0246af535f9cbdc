//! Contract: the README's algorithm table is the one `slamlab algorithms --markdown` prints (the
//! catalogue's names, titles, families, sensors, sections and summaries), so that a new
//! algorithm cannot be missing from it.

use crate::util::{ok, repo};

#[test]
fn the_readme_algorithm_table_is_generated_from_the_catalogue() {
    let table = String::from_utf8(ok(&["algorithms", "--markdown"]).stdout).unwrap();
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let begin = readme.find("<!-- algorithms:begin").expect("README marks its algorithm table");
    let body = &readme[begin..];
    let body = &body[body.find('\n').unwrap() + 1..];
    let block = &body[..body.find("<!-- algorithms:end -->").expect("the table's end marker")];
    assert_eq!(
        block, table,
        "README.md's algorithm table is out of date: run `make report` (or tests/tools/readme_block.sh write README.md <(slamlab algorithms --markdown) algorithms)"
    );
    // every built-in and the repository's external example are listed
    for name in ["odometry", "fastslam1", "ekf_slam", "psm", "tnewton", "ekf_slam_py"] {
        assert!(table.contains(&format!("| `{name}` |")), "{name} missing");
    }
}
