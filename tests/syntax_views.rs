//! Typed views: what a transformer reads off blocks.

mod syntax_support;

use driftloop::parse;
use driftloop::views::{
    Access, AddressValue, AxisMode, Value, VarName, WorkOffset, facts, program_facts,
    used_r_parameters, user_variables,
};
use syntax_support::fixture;

fn numbers(values: &[AddressValue]) -> Vec<(Option<u32>, Value)> {
    values
        .iter()
        .map(|v| (v.extension, v.value.clone()))
        .collect()
}

#[test]
fn words_give_tools_spindle_feed_motion_and_axes() {
    let p = parse(&fixture("words.mpf"));
    let f: Vec<_> = program_facts(&p).collect();
    assert_eq!(f[0].block_number, Some(10));
    assert_eq!(f[0].motion, vec![0]);
    assert_eq!(f[0].g_codes, vec![0, 90, 17]);
    assert_eq!(numbers(&f[1].tools), vec![(None, Value::Number(1.0))]);
    assert_eq!(numbers(&f[1].m_codes), vec![(None, Value::Number(6.0))]);
    assert_eq!(
        numbers(&f[2].spindle_speeds),
        vec![(None, Value::Number(2000.0))]
    );
    let axes: Vec<(String, Value)> = f[3]
        .axes
        .iter()
        .map(|a| (a.axis.clone(), a.value.clone()))
        .collect();
    assert_eq!(
        axes,
        vec![
            ("X".into(), Value::Number(12.345)),
            ("Y".into(), Value::Number(-3.2)),
            ("Z".into(), Value::Number(0.5))
        ]
    );
    assert_eq!(
        f[3].feed.as_ref().map(|v| v.value.clone()),
        Some(Value::Number(800.0))
    );
    assert_eq!(numbers(&f[4].m_codes), vec![(Some(3), Value::Number(5.0))]);
    assert_eq!(
        numbers(&f[4].spindle_speeds),
        vec![(Some(1), Value::Number(1000.0))]
    );
    assert_eq!(
        numbers(&f[4].tools),
        vec![(None, Value::Text("FACE MILL 50".into()))]
    );
    let modes: Vec<(String, AxisMode)> = f[5]
        .axes
        .iter()
        .chain(&f[6].axes)
        .map(|a| (a.axis.clone(), a.mode))
        .collect();
    assert_eq!(
        modes,
        vec![
            ("X".into(), AxisMode::Modal),
            ("Y".into(), AxisMode::Ic),
            ("Z".into(), AxisMode::Ac),
            ("A".into(), AxisMode::Dc),
            ("B".into(), AxisMode::Acp),
            ("C".into(), AxisMode::Acn)
        ]
    );
    assert_eq!(f[5].axes[2].value, Value::Number(-2.5));
    assert!(
        matches!(f[5].axes[0].value, Value::Expr(_)),
        "X=R1+5 is an expression"
    );
    assert_eq!(f[7].motion, vec![2]);
    assert_eq!(f[11].axes[0].value, Value::Number(1500.0), "1.5EX3");
}

#[test]
fn variables_read_written_and_declared() {
    let p = parse(&fixture("parameters.mpf"));
    let block = |i| {
        facts(&p.block(i))
            .variables
            .into_iter()
            .map(|v| (v.name, v.access))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        block(0),
        vec![
            (VarName::R(Some(1)), Access::Write),
            (VarName::R(Some(2)), Access::Write),
            (VarName::R(Some(1)), Access::Read)
        ]
    );
    assert_eq!(
        block(1),
        vec![
            (VarName::R(Some(2)), Access::Write),
            (VarName::R(None), Access::Write),
            (VarName::R(Some(1)), Access::Read),
            (VarName::R(Some(2)), Access::Read)
        ]
    );
    assert_eq!(
        block(2),
        vec![(VarName::User("COUNT".into()), Access::Declare)]
    );
    assert_eq!(
        block(4),
        vec![
            (VarName::R(Some(1)), Access::Read),
            (VarName::User("COUNT".into()), Access::Read)
        ],
        "axis targets are not variables, their values are read"
    );
    assert_eq!(
        used_r_parameters(&p).into_iter().collect::<Vec<_>>(),
        vec![1, 2]
    );
    assert_eq!(
        user_variables(&p).into_iter().collect::<Vec<_>>(),
        vec!["COUNT".to_string()]
    );
}

#[test]
fn system_variables_and_for_loops() {
    let p = parse(&fixture("sysvars.mpf"));
    let f = facts(&p.block(1));
    let names: Vec<_> = f
        .variables
        .iter()
        .map(|v| (v.name.clone(), v.access))
        .collect();
    assert_eq!(
        names,
        vec![
            (VarName::R(Some(1)), Access::Write),
            (VarName::System("$AA_IM".into()), Access::Read),
            (VarName::System("$AC_MEA".into()), Access::Read)
        ]
    );
    let p = parse(&fixture("control.mpf"));
    let f = facts(&p.block(8));
    assert_eq!(f.variables[0].name, VarName::R(Some(3)));
    assert_eq!(f.variables[0].access, Access::Write);
}

#[test]
fn work_offsets_and_frames() {
    let p = parse(&fixture("frames.mpf"));
    let offsets: Vec<WorkOffset> = program_facts(&p).flat_map(|f| f.work_offsets).collect();
    assert_eq!(
        offsets,
        vec![
            WorkOffset::G(54),
            WorkOffset::G(505),
            WorkOffset::G(500),
            WorkOffset::Frame("TRANS".into()),
            WorkOffset::Frame("ATRANS".into()),
            WorkOffset::Frame("ROT".into()),
            WorkOffset::Frame("AROT".into()),
            WorkOffset::Frame("SCALE".into()),
            WorkOffset::Frame("MIRROR".into()),
            WorkOffset::FrameWrite("$P_UIFR".into()),
            WorkOffset::Frame("SUPA".into()),
        ]
    );
    let p = parse(&fixture("sysvars.mpf"));
    assert_eq!(
        facts(&p.block(0)).work_offsets,
        vec![WorkOffset::FrameWrite("$P_UIFR".into())]
    );
}

#[test]
fn labels_and_block_numbers() {
    let p = parse(&fixture("block_numbers.mpf"));
    let f: Vec<_> = program_facts(&p)
        .map(|f| (f.block_number, f.label))
        .collect();
    assert_eq!(
        f,
        vec![
            (Some(10), None),
            (Some(20), None),
            (Some(30), None),
            (Some(40), None),
            (None, Some("START".into())),
            (Some(50), Some("AB_12".into())),
            (Some(60), None)
        ]
    );
}

#[test]
fn predefined_addresses_are_not_user_variables() {
    let p = parse(b"G2 X10 Y0 CR=5 ANG=30 SPOS=90 ID=1 WHENEVER TRUE DO LIMIT=2\n");
    assert_eq!(
        user_variables(&p).into_iter().collect::<Vec<_>>(),
        vec!["LIMIT".to_string()]
    );
}

#[test]
fn calls_and_commands_by_name() {
    let p = parse(&fixture("calls.mpf"));
    let calls: Vec<String> = program_facts(&p).flat_map(|f| f.calls).collect();
    assert_eq!(
        calls,
        vec![
            "SUBPROG", "SUBPROG", "CYCLE800", "MSG", "SETAL", "STOPRE", "WRITE", "RET"
        ]
    );
}
