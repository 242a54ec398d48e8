//! Rotation, scale and mirror of the programmable frame place the geometry axes; inverse-time feed times a
//! block by its F; swivel cycles and transformations run (recorded, not modelled).

use driftloop::vm::{Config, Run, SimpleMachine, run_source};

fn run(src: &str) -> Run {
    run_source(
        "t.mpf",
        src.as_bytes(),
        None,
        &Config::default(),
        &mut SimpleMachine::cold(),
    )
    .unwrap()
}

/// Machine X, Y, Z after the last block.
fn last_xyz(run: &Run) -> [f64; 3] {
    let m = &run.trace.last().unwrap().machine;
    [m[0], m[1], m[2]]
}

fn assert_near(got: [f64; 3], want: [f64; 3]) {
    for k in 0..3 {
        assert!((got[k] - want[k]).abs() < 1e-9, "{got:?} vs {want:?}");
    }
}

#[test]
fn rot_turns_the_programmed_contour_about_the_origin() {
    assert_near(last_xyz(&run("ROT Z90\nG0 X10 Y0 Z5\n")), [0.0, 10.0, 5.0]);
    // RPL turns in the working plane: G18 turns about Y, from Z towards X.
    assert_near(
        last_xyz(&run("G18\nROT RPL=90\nG0 X0 Y0 Z10\n")),
        [10.0, 0.0, 0.0],
    );
    // TRANS first, then the rotation about the shifted origin; ATRANS after it shifts along the turned axis.
    assert_near(
        last_xyz(&run("TRANS X100\nAROT Z90\nG0 X10 Y0 Z0\n")),
        [100.0, 10.0, 0.0],
    );
    assert_near(
        last_xyz(&run("ROT Z90\nATRANS X5\nG0 X0 Y0 Z0\n")),
        [0.0, 5.0, 0.0],
    );
    // RPY: Z first, then the new Y. X programmed lands on -Z after Z90 then Y90.
    assert_near(
        last_xyz(&run("ROT Z90 Y90\nG0 X10 Y0 Z0\n")),
        [0.0, 0.0, -10.0],
    );
    // A bare ROT deletes the programmable frame.
    assert_near(
        last_xyz(&run("ROT Z90\nROT\nG0 X10 Y0 Z0\n")),
        [10.0, 0.0, 0.0],
    );
}

#[test]
fn scale_and_mirror_act_on_their_axes_and_chain() {
    assert_near(
        last_xyz(&run("SCALE X2 Y3\nG0 X1 Y1 Z1\n")),
        [2.0, 3.0, 1.0],
    );
    assert_near(last_xyz(&run("MIRROR X0\nG0 X4 Y1 Z1\n")), [-4.0, 1.0, 1.0]);
    assert_near(
        last_xyz(&run("MIRROR X0\nAMIRROR X0\nG0 X4 Y1 Z1\n")),
        [4.0, 1.0, 1.0],
    );
    // ATRANS after SCALE is scaled too.
    assert_near(
        last_xyz(&run("SCALE X2\nATRANS X5\nG0 X0 Y0 Z0\n")),
        [10.0, 0.0, 0.0],
    );
}

#[test]
fn inverse_time_feed_takes_one_over_f_minutes() {
    let r = run("G93 G1 X100 F4\nG1 X0 F0.5\n");
    assert!((r.time_min - 2.25).abs() < 1e-9, "{}", r.time_min);
}

#[test]
fn swivels_and_transformations_run() {
    let r = run(
        "CYCLE800(1,\"TC1\",0,57,0,0,0,30,0,0,0,0,0,-1,100,1)\nG0 X1\nCYCLE800()\nTRAORI\nG0 X2\nTRAFOOF\nTRACYL(40)\nTRAFOOF\nTRANSMIT\nTRAFOOF\n",
    );
    assert_eq!(r.trace.len(), 10);
}
