//! Bad networks give clear errors naming the place, never a panic (one test per case).

use shadenet_graph::{CompileError, LinkError, NodeLibrary, compile_json};

fn errors(src: &str) -> Vec<LinkError> {
    match compile_json(src, &NodeLibrary::standard()) {
        Err(CompileError::Link(e)) => e.0,
        Err(e) => panic!("expected link errors, got {e}"),
        Ok(_) => panic!("expected link errors, the network compiled"),
    }
}

fn one(src: &str) -> String {
    let e = errors(src);
    assert_eq!(e.len(), 1, "expected one error, got {e:#?}");
    e[0].to_string()
}

#[test]
fn malformed_json_reports_line_and_column() {
    let src = "{\n  \"nodes\": [\n    {\"name\": \"a\", \"type\": \"checker\",}\n  ]\n}";
    match compile_json(src, &NodeLibrary::standard()) {
        Err(CompileError::Parse(e)) => {
            assert_eq!(e.line(), 3, "{e}");
            assert!(e.to_string().contains("line 3"), "{e}");
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn unknown_top_level_key_is_an_error() {
    let src = r#"{"nodes": [], "ouputs": {}}"#;
    match compile_json(src, &NodeLibrary::standard()) {
        Err(CompileError::Parse(e)) => assert!(e.to_string().contains("ouputs"), "{e}"),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn unknown_node_type_names_node_and_suggests() {
    let m =
        one(r#"{"nodes": [{"name": "chk", "type": "chekcer"}], "outputs": {"c": "chk.outColor"}}"#);
    assert!(m.contains("node `chk`") && m.contains("`chekcer`"), "{m}");
    assert!(m.contains("did you mean `checker`"), "{m}");
}

#[test]
fn unknown_port_lists_valid_ports() {
    let m = one(
        r#"{"nodes": [{"name": "chk", "type": "checker", "inputs": {"colour1": [1,0,0]}}],
            "outputs": {"c": "chk.outColor"}}"#,
    );
    assert!(
        m.contains("node `chk` (checker): unknown input `colour1`"),
        "{m}"
    );
    assert!(m.contains("color1"), "{m}");
}

#[test]
fn type_mismatch_names_port_and_both_types() {
    let m = one(r#"{"nodes": [
              {"name": "uvs", "type": "place2d"},
              {"name": "surf", "type": "lambert", "inputs": {"color": "uvs.outUV"}}],
            "outputs": {"c": "surf.outColor"}}"#);
    assert!(m.contains("node `surf` input `color`"), "{m}");
    assert!(
        m.contains("color") && m.contains("vec2") && m.contains("uvs.outUV"),
        "{m}"
    );
}

#[test]
fn cycle_is_reported_with_its_path() {
    let m = one(r#"{"nodes": [
              {"name": "a", "type": "multiply", "inputs": {"input1": "b.out"}},
              {"name": "b", "type": "multiply", "inputs": {"input1": "a.out"}}],
            "outputs": {"c": "a.out"}}"#);
    assert!(m.starts_with("cycle: "), "{m}");
    assert!(m.contains("a → b → a") || m.contains("b → a → b"), "{m}");
}

#[test]
fn self_loop_is_a_cycle() {
    let m = one(
        r#"{"nodes": [{"name": "a", "type": "add", "inputs": {"input1": "a.out"}}],
            "outputs": {"c": "a.out"}}"#,
    );
    assert_eq!(m, "cycle: a → a");
}

#[test]
fn dangling_connection_names_missing_node() {
    let m = one(
        r#"{"nodes": [{"name": "surf", "type": "lambert", "inputs": {"color": "tex.outColor"}}],
            "outputs": {"c": "surf.outColor"}}"#,
    );
    assert!(
        m.contains("node `surf` input `color`") && m.contains("no node `tex`"),
        "{m}"
    );
}

#[test]
fn unknown_output_port_lists_outputs() {
    let m = one(r#"{"nodes": [
              {"name": "chk", "type": "checker"},
              {"name": "surf", "type": "lambert", "inputs": {"color": "chk.outColour"}}],
            "outputs": {"c": "surf.outColor"}}"#);
    assert!(
        m.contains("has no output `outColour`") && m.contains("outColor"),
        "{m}"
    );
}

#[test]
fn duplicate_names_are_reported() {
    let m = one(
        r#"{"nodes": [{"name": "a", "type": "checker"}, {"name": "a", "type": "checker"}],
            "outputs": {"c": "a.outColor"}}"#,
    );
    assert_eq!(m, "duplicate node name `a`");
}

#[test]
fn bad_component_is_reported() {
    let m = one(r#"{"nodes": [
              {"name": "chk", "type": "checker"},
              {"name": "surf", "type": "lambert", "inputs": {"diffuse": "chk.outColor.w"}}],
            "outputs": {"c": "surf.outColor"}}"#);
    assert!(m.contains("`w` is not a component"), "{m}");
}

#[test]
fn out_of_range_and_wrong_shape_literals() {
    let e = errors(
        r#"{"nodes": [{"name": "surf", "type": "lambert",
              "inputs": {"diffuse": 1e39, "color": [1, 2], "transparency": "x.y.z.w"}}],
            "outputs": {"c": "surf.outColor"}}"#,
    );
    let all: Vec<String> = e.iter().map(|e| e.to_string()).collect();
    assert_eq!(all.len(), 3, "{all:#?}");
    assert!(
        all.iter()
            .any(|m| m.contains("`diffuse`") && m.contains("out of range")),
        "{all:#?}"
    );
    assert!(
        all.iter()
            .any(|m| m.contains("`color`") && m.contains("3 numbers")),
        "{all:#?}"
    );
    assert!(
        all.iter()
            .any(|m| m.contains("`transparency`") && m.contains("not a connection")),
        "{all:#?}"
    );
}

#[test]
fn invalid_option_lists_choices() {
    let m = one(
        r#"{"nodes": [{"name": "s", "type": "samplerInfo", "inputs": {"space": "screen"}}],
            "outputs": {"p": "s.P"}}"#,
    );
    assert!(
        m.contains("`screen` is not one of: world, camera, object"),
        "{m}"
    );
}

#[test]
fn no_outputs_is_an_error() {
    let e = errors(r#"{"nodes": [{"name": "a", "type": "checker"}]}"#);
    assert_eq!(e, vec![LinkError::NoOutputs]);
}

#[test]
fn every_error_is_reported_not_just_the_first() {
    let e = errors(
        r#"{"nodes": [
              {"name": "a", "type": "nope"},
              {"name": "b", "type": "checker", "inputs": {"bogus": 1}},
              {"name": "c", "type": "lambert", "inputs": {"color": "zzz.out"}}],
            "outputs": {"c": "c.outColor"}}"#,
    );
    assert_eq!(e.len(), 3, "{e:#?}");
}

#[test]
fn connection_to_a_light_is_rejected() {
    let m = one(r#"{"nodes": [
              {"name": "l", "type": "pointLight"},
              {"name": "s", "type": "lambert", "inputs": {"color": "l.color"}}],
            "outputs": {"c": "s.outColor"}}"#);
    assert!(m.contains("node `s` input `color`"), "{m}");
}

#[test]
fn compound_recursion_and_missing_input() {
    let e = errors(
        r#"{"nodes": [{"name": "x", "type": "loop"}, {"name": "y", "type": "needs"}],
            "outputs": {"c": "y.out"},
            "compounds": [
              {"name": "loop", "outputs": {"out": "i.out"},
               "nodes": [{"name": "i", "type": "loop"}]},
              {"name": "needs", "inputs": [{"name": "k", "type": "float"}],
               "outputs": {"out": "m.out"},
               "nodes": [{"name": "m", "type": "multiply", "inputs": {"input1": "$k"}}]}
            ]}"#,
    );
    let all: Vec<String> = e.iter().map(|e| e.to_string()).collect();
    assert!(
        all.iter()
            .any(|m| m.contains("compound `loop`: uses itself")),
        "{all:#?}"
    );
    assert!(
        all.iter()
            .any(|m| m.contains("node `y` input `k`") && m.contains("requires")),
        "{all:#?}"
    );
}

#[test]
fn compound_inner_errors_name_the_inner_node() {
    let m = one(r#"{"nodes": [{"name": "inst", "type": "c"}],
            "outputs": {"o": "inst.out"},
            "compounds": [{"name": "c", "outputs": {"out": "m.out"},
               "nodes": [{"name": "m", "type": "multiply", "inputs": {"input1": "ghost.out"}}]}]}"#);
    assert!(
        m.contains("node `inst/m` input `input1`") && m.contains("no node `inst/ghost`"),
        "{m}"
    );
}

#[test]
fn dollar_reference_outside_a_compound() {
    let m = one(
        r#"{"nodes": [{"name": "m", "type": "multiply", "inputs": {"input1": "$k"}}],
            "outputs": {"o": "m.out"}}"#,
    );
    assert!(m.contains("outside any compound"), "{m}");
}

#[test]
fn unknown_node_type_does_not_cascade_into_dangling_errors() {
    let e = errors(
        r#"{"nodes": [
              {"name": "tex", "type": "nosuchnode"},
              {"name": "s", "type": "lambert", "inputs": {"color": "tex.outColor"}}],
            "outputs": {"c": "s.outColor", "t": "tex.outColor"}}"#,
    );
    assert_eq!(e.len(), 1, "{e:#?}");
}
