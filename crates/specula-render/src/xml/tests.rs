//! Tests of the XML reader. Expected matrices were printed by Mitsuba 3.9.1 (`scalar_rgb`):
//! `mi.ScalarTransform4f().rotate(...)` / `.look_at(...)`, or `mi.load_string` of the same
//! `<transform>` and `mi.traverse(scene)['id.to_world']`.

use super::parse::to_snake_case;
use super::*;
use std::path::{Path, PathBuf};

fn parse(text: &str) -> Result<Node> {
    parse_scene_str(text, "test.xml", Path::new("."), &[])
}

fn parse_with(text: &str, overrides: &[(&str, &str)]) -> Result<Node> {
    let o: Vec<(String, String)> = overrides
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    parse_scene_str(text, "test.xml", Path::new("."), &o)
}

fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{body}\n</scene>\n")
}

/// The one shape of a scene whose body is a single `<shape>`.
fn first(node: &Node) -> &Node {
    &node.children[0]
}

/// Row-major rows of a matrix.
fn rows(m: Mat4) -> [[f32; 4]; 4] {
    m.transpose().to_cols_array_2d()
}

fn assert_mat(m: Mat4, expected: [[f32; 4]; 3], what: &str) {
    let r = rows(m);
    for i in 0..3 {
        for j in 0..4 {
            assert!(
                (r[i][j] - expected[i][j]).abs() < 2e-6,
                "{what}: entry ({i},{j}) is {} but Mitsuba gives {}\nfull: {r:?}",
                r[i][j],
                expected[i][j]
            );
        }
    }
    assert_eq!(r[3], [0.0, 0.0, 0.0, 1.0], "{what}: last row");
}

/// The to_world of a scene with one shape whose transform holds `ops`.
fn to_world(ops: &str) -> Mat4 {
    let s = scene(&format!(
        "<shape type=\"rectangle\"><transform name=\"to_world\">{ops}</transform></shape>"
    ));
    let root = parse(&s).unwrap_or_else(|e| panic!("{ops}: {e}"));
    first(&root).transform("to_world").unwrap().unwrap()
}

// ---------------------------------------------------------------------------------------------
// The repository's scenes

fn shared_scenes() -> Option<Vec<PathBuf>> {
    let dir = specula_testdata::shared("scenes")?;
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no scenes in {}", dir.display());
    Some(files)
}

#[test]
fn parses_every_shared_scene() {
    let Some(files) = shared_scenes() else { return };
    for f in &files {
        let root = load_scene(f, &[]).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(root.tag, "scene");
        assert_eq!(root.loc.file, f.display().to_string());
        let sensor = root
            .children_with_tag("sensor")
            .next()
            .unwrap_or_else(|| panic!("{}: no sensor", f.display()));
        assert!(sensor.transform("to_world").unwrap().is_some());
        let sampler = sensor.children_with_tag("sampler").next().unwrap();
        assert_eq!(
            sampler.int("sample_count", 0).unwrap(),
            64,
            "{}",
            f.display()
        );
        // Overrides of the declared parameters replace the defaults.
        let o = [
            ("spp".to_string(), "4".to_string()),
            ("resx".to_string(), "32".to_string()),
        ];
        let root = load_scene(f, &o).unwrap_or_else(|e| panic!("{e}"));
        let sensor = root.children_with_tag("sensor").next().unwrap();
        let sampler = sensor.children_with_tag("sampler").next().unwrap();
        assert_eq!(sampler.int("sample_count", 0).unwrap(), 4);
        let film = sensor.children_with_tag("film").next().unwrap();
        assert_eq!(film.int("width", 0).unwrap(), 32);
    }
}

#[test]
fn cornell_box_matches_mitsuba() {
    let Some(files) = shared_scenes() else { return };
    let Some(cbox) = files.iter().find(|f| f.ends_with("cbox.xml")) else {
        return;
    };
    let root = load_scene(cbox, &[]).unwrap();
    let sensor = root.children_with_tag("sensor").next().unwrap();
    assert_eq!(sensor.plugin_type, "perspective");
    assert_eq!(sensor.float("fov", 0.0).unwrap(), 39.3077);
    assert_mat(
        sensor.transform("to_world").unwrap().unwrap(),
        [
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 4.1],
        ],
        "cbox camera",
    );
    let small = root
        .children
        .iter()
        .find(|c| c.id.as_deref() == Some("small_box"))
        .unwrap();
    assert_eq!(
        (small.tag.as_str(), small.plugin_type.as_str()),
        ("shape", "cube")
    );
    assert_mat(
        small.transform("to_world").unwrap().unwrap(),
        [
            [0.2853169, 0.0, -0.0927051, 0.335],
            [0.0, 0.3, 0.0, -0.7],
            [0.0927051, 0.0, 0.2853169, 0.38],
        ],
        "cbox small_box",
    );
    let r = &small.children[0];
    assert_eq!(
        (r.tag.as_str(), r.id.as_deref(), r.name.as_deref()),
        ("ref", Some("white"), None)
    );
    let light = root
        .children
        .iter()
        .find(|c| c.id.as_deref() == Some("light"))
        .unwrap();
    let tags: Vec<&str> = light.children.iter().map(|c| c.tag.as_str()).collect();
    assert_eq!(tags, ["ref", "emitter"]);
    assert_eq!(
        light.children[1].rgb("radiance", [0.0; 3]).unwrap(),
        [18.387, 13.9873, 6.75357]
    );
    let white = root
        .children
        .iter()
        .find(|c| c.id.as_deref() == Some("white"))
        .unwrap();
    assert_eq!(
        (white.tag.as_str(), white.plugin_type.as_str()),
        ("bsdf", "diffuse")
    );
    // Locations: line and column of the element.
    assert_eq!((white.loc.line, white.loc.col), (22, 5));
    assert_eq!(white.props[0].loc.line, 23);
}

// ---------------------------------------------------------------------------------------------
// Properties

#[test]
fn property_values() {
    let s = scene(
        r#"<shape type="test">
    <float name="f" value=" 1e-1 "/>
    <integer name="i" value="-7"/>
    <boolean name="b" value="True"/>
    <boolean name="b2" value="false"/>
    <string name="s" value="a b"/>
    <rgb name="c" value="0.1, 0.2 0.3"/>
    <rgb name="c1" value="0.25"/>
    <spectrum name="sp" value="0.5"/>
    <point name="p" value="1, 2, 3"/>
    <point name="p1" x="4" z="5"/>
    <point name="p2" value="2"/>
    <vector name="v" x="1" y="-1" z="0.5"/>
</shape>"#,
    );
    let root = parse(&s).unwrap();
    let n = first(&root);
    let v: Vec<(&str, &PropValue)> = n
        .props
        .iter()
        .map(|p| (p.name.as_str(), &p.value))
        .collect();
    assert_eq!(
        v,
        [
            ("f", &PropValue::Float(0.1)),
            ("i", &PropValue::Int(-7)),
            ("b", &PropValue::Bool(true)),
            ("b2", &PropValue::Bool(false)),
            ("s", &PropValue::Str("a b".into())),
            ("c", &PropValue::Rgb([0.1, 0.2, 0.3])),
            ("c1", &PropValue::Rgb([0.25; 3])),
            ("sp", &PropValue::Spectrum(Spectrum::Constant(0.5))),
            ("p", &PropValue::Point(Vec3::new(1.0, 2.0, 3.0))),
            ("p1", &PropValue::Point(Vec3::new(4.0, 0.0, 5.0))),
            ("p2", &PropValue::Point(Vec3::splat(2.0))),
            ("v", &PropValue::Vector(Vec3::new(1.0, -1.0, 0.5))),
        ]
    );
    assert_eq!(
        n.props[1].loc,
        Loc {
            file: "test.xml".into(),
            line: 4,
            col: 5
        }
    );
}

#[test]
fn nested_plugins_and_refs() {
    let s = scene(
        r#"<bsdf type="diffuse" id="white"/>
<shape type="sphere" id="ball" name="ignored">
    <bsdf type="diffuse">
        <texture type="checkerboard" name="reflectance">
            <rgb name="color0" value="1"/>
        </texture>
    </bsdf>
    <ref id="white" name="interior"/>
    <emitter type="area"><rgb name="radiance" value="1, 2, 3"/></emitter>
</shape>
<sensor type="perspective">
    <sampler type="independent"/>
    <film type="hdrfilm"><rfilter type="box"/></film>
</sensor>"#,
    );
    let root = parse(&s).unwrap();
    let tags: Vec<&str> = root.children.iter().map(|c| c.tag.as_str()).collect();
    assert_eq!(tags, ["bsdf", "shape", "sensor"]);
    let ball = &root.children[1];
    assert_eq!(ball.id.as_deref(), Some("ball"));
    assert_eq!(ball.name.as_deref(), Some("ignored"));
    let kinds: Vec<(&str, &str)> = ball
        .children
        .iter()
        .map(|c| (c.tag.as_str(), c.plugin_type.as_str()))
        .collect();
    assert_eq!(
        kinds,
        [("bsdf", "diffuse"), ("ref", ""), ("emitter", "area")]
    );
    let tex = ball.children[0].child_named("reflectance").unwrap();
    assert_eq!(
        (tex.tag.as_str(), tex.plugin_type.as_str()),
        ("texture", "checkerboard")
    );
    let r = ball.child_named("interior").unwrap();
    assert_eq!(r.id.as_deref(), Some("white"));
    assert_eq!(r.describe(), "ref 'white'");
    let sensor = &root.children[2];
    assert_eq!(sensor.children[1].children[0].tag, "rfilter");
}

#[test]
fn accessors_and_type_errors() {
    let s = scene(
        r#"<shape type="sphere">
    <integer name="n" value="3"/>
    <spectrum name="k" value="0.5"/>
    <float name="x" value="2"/>
    <vector name="center" value="1 2 3"/>
    <rgb name="c" value="1 2 3"/>
</shape>"#,
    );
    let root = parse(&s).unwrap();
    let n = first(&root);
    assert_eq!(
        n.float("n", 0.0).unwrap(),
        3.0,
        "an integer is a valid float"
    );
    assert_eq!(n.rgb("k", [0.0; 3]).unwrap(), [0.5; 3]);
    assert_eq!(n.rgb("x", [0.0; 3]).unwrap(), [2.0; 3]);
    assert_eq!(
        n.point("center", Vec3::ZERO).unwrap(),
        Vec3::new(1.0, 2.0, 3.0)
    );
    assert_eq!(n.float("missing", 7.5).unwrap(), 7.5);
    assert_eq!(n.string("missing", "dflt").unwrap(), "dflt");
    assert_eq!(n.float_opt("missing").unwrap(), None);
    assert!(n.has("c") && !n.has("missing"));
    let e = n.float("c", 0.0).unwrap_err();
    assert_eq!(
        e.loc,
        Some(Loc {
            file: "test.xml".into(),
            line: 7,
            col: 5
        })
    );
    let text = e.to_string();
    assert!(text.starts_with("test.xml:7:5: "), "{text}");
    assert!(text.contains("parameter 'c' of shape 'sphere'"), "{text}");
    assert!(text.contains("expected float, found rgb"), "{text}");
    let e = n.int("x", 0).unwrap_err().to_string();
    assert!(
        e.contains("test.xml:5:5") && e.contains("expected integer, found float"),
        "{e}"
    );
    let e = n.string("x", "").unwrap_err().to_string();
    assert!(e.contains("expected string, found float"), "{e}");
    let e = n.transform("x").unwrap_err().to_string();
    assert!(e.contains("expected transform, found float"), "{e}");
    let e = n.bool("n", false).unwrap_err().to_string();
    assert!(e.contains("expected boolean, found integer"), "{e}");
}

#[test]
fn check_unused_reports_unread_parameters() {
    let s = scene(
        r#"<shape type="sphere">
    <float name="radius" value="1"/>
    <boolean name="flip_normals" value="true"/>
    <float name="foo" value="2"/>
</shape>"#,
    );
    let root = parse(&s).unwrap();
    let n = first(&root);
    let valid = ["center", "radius", "to_world", "flip_normals"];
    assert_eq!(n.float("radius", 0.0).unwrap(), 1.0);
    let e = n.check_unused(&valid).unwrap_err();
    assert_eq!(
        e.loc,
        Some(Loc {
            file: "test.xml".into(),
            line: 5,
            col: 5
        })
    );
    assert_eq!(
        e.to_string(),
        "test.xml:5:5: unknown parameter 'foo' for shape 'sphere'; valid parameters: center, \
         radius, to_world, flip_normals"
    );
    // Reading it (even if it is not listed) satisfies the check; unread valid names are fine.
    assert!(n.prop("foo").is_some());
    n.check_unused(&valid).unwrap();
    assert!(n
        .props
        .iter()
        .all(|p| p.name == "flip_normals" || p.is_used()));
    let e = root.children[0].clone();
    e.mark_all_used();
    e.check_unused(&[]).unwrap();
    let fresh = parse(&s).unwrap();
    let e = first(&fresh).check_unused(&[]).unwrap_err().to_string();
    assert!(
        e.contains("unknown parameter 'radius' for shape 'sphere'; it takes no parameters"),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Parameters

#[test]
fn defaults_and_overrides() {
    let s = r#"<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="r" value="2"/>
    <default name="r0" value="3"/>
    <default name="name" value="ball"/>
    <default name="both" value="$r$r0"/>
    <default name="r" value="999"/>
    <shape type="sphere" id="$name">
        <float name="a" value="$r"/>
        <float name="b" value="$r0"/>
        <string name="c" value="x_${r}_$spp.exr"/>
        <string name="d" value="$r_suffix"/>
        <integer name="e" value="$both"/>
        <integer name="f" value="$spp"/>
    </shape>
</scene>"#;
    let root = parse(s).unwrap();
    let n = first(&root);
    assert_eq!(n.id.as_deref(), Some("ball"));
    assert_eq!(
        n.float("a", 0.0).unwrap(),
        2.0,
        "the first <default> wins, as in Mitsuba"
    );
    assert_eq!(
        n.float("b", 0.0).unwrap(),
        3.0,
        "the longest parameter name matches"
    );
    assert_eq!(n.string("c", "").unwrap(), "x_2_64.exr");
    assert_eq!(
        n.string("d", "").unwrap(),
        "2_suffix",
        "Mitsuba: `$r_suffix` is `$r` + `_suffix`"
    );
    assert_eq!(n.int("e", 0).unwrap(), 23);
    let root = parse_with(s, &[("spp", "4"), ("r", "5"), ("spp", "8")]).unwrap();
    let n = first(&root);
    assert_eq!(n.float("a", 0.0).unwrap(), 5.0);
    assert_eq!(
        n.int("f", 0).unwrap(),
        8,
        "the last of repeated overrides wins"
    );
    assert_eq!(n.int("e", 0).unwrap(), 53);
    // An override may also supply a parameter the scene uses without a default (Mitsuba does).
    let t = scene(r#"<shape type="sphere"><float name="radius" value="$rad"/></shape>"#);
    let root = parse_with(&t, &[("rad", "1.5")]).unwrap();
    assert_eq!(first(&root).float("radius", 0.0).unwrap(), 1.5);
}

#[test]
fn parameter_errors() {
    let s = r#"<scene version="3.0.0">
    <default name="spp" value="64"/>
    <default name="res" value="64"/>
</scene>"#;
    let e = parse_with(s, &[("sp", "4")]).unwrap_err().to_string();
    assert!(
        e.contains("parameter 'sp' given as an override (-D sp=4) is not declared"),
        "{e}"
    );
    assert!(e.contains("declared parameters: spp, res"), "{e}");
    let e = parse_with(&scene(""), &[("x", "1")])
        .unwrap_err()
        .to_string();
    assert!(e.contains("the scene declares no parameters"), "{e}");
    // Used before its declaration.
    let s = r#"<scene version="3.0.0">
    <shape type="sphere"><float name="radius" value="$r"/></shape>
    <default name="r" value="1"/>
</scene>"#;
    let e = parse(s).unwrap_err().to_string();
    assert!(
        e.starts_with("test.xml:2:26: undefined parameter '$r'"),
        "{e}"
    );
    assert!(e.contains("no parameters are defined"), "{e}");
    let e = parse(&scene(
        r#"<default name="a" value="1"/><shape type="${b}"/>"#,
    ))
    .unwrap_err();
    assert!(e.to_string().contains("undefined parameter '$b'"), "{e}");
    assert!(e.to_string().contains("defined parameters: a"), "{e}");
    let e = parse(&scene(r#"<shape type="${b"/>"#))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unterminated '${'"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Transforms

#[test]
fn rotate_matches_mitsuba() {
    // mi.ScalarTransform4f().rotate([0, 1, 0], -18)
    assert_mat(
        to_world(r#"<rotate y="1" angle="-18"/>"#),
        [
            [0.9510565, 0.0, -0.309017, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.309017, 0.0, 0.9510565, 0.0],
        ],
        "rotate y -18",
    );
    // mi.ScalarTransform4f().rotate([1, 0, 0], 90)
    assert_mat(
        to_world(r#"<rotate x="1" angle="90"/>"#),
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
        ],
        "rotate x 90",
    );
    // mi.ScalarTransform4f().rotate([0.6, 0, 0.8], 120), given as value= and as axis=.
    let expected = [
        [0.03999996, -0.6928203, 0.72, 0.0],
        [0.6928203, -0.5000001, -0.5196152, 0.0],
        [0.72, 0.5196152, 0.46, 0.0],
    ];
    assert_mat(
        to_world(r#"<rotate value="0.6, 0, 0.8" angle="120"/>"#),
        expected,
        "rotate value",
    );
    assert_mat(
        to_world(r#"<rotate axis="0.6 0 0.8" angle="120"/>"#),
        expected,
        "rotate axis",
    );
    // Mitsuba does not normalise the axis: rotate([1, 2, 3], 37).
    assert_mat(
        to_world(r#"<rotate x="1" y="2" z="3" angle="37"/>"#),
        [
            [1.0, -1.402716, 1.807724, 0.0],
            [2.208174, 1.604094, 0.6063721, 0.0],
            [-0.5995364, 1.810002, 2.610916, 0.0],
        ],
        "rotate (1,2,3) 37",
    );
}

#[test]
fn lookat_matches_mitsuba() {
    // mi.ScalarTransform4f().look_at(origin=[-2.5, 4.5, -2], target=[0, 1, 0], up=[0, 1, 0])
    assert_mat(
        to_world(r#"<lookat origin="-2.5, 4.5, -2.0" target="0, 1, 0" up="0, 1, 0"/>"#),
        [
            [0.624695, 0.5761756, 0.5270463, -2.5],
            [0.0, 0.6749485, -0.7378648, 4.5],
            [-0.7808688, 0.4609405, 0.421637, -2.0],
        ],
        "lookat key light",
    );
    // look_at(origin=[0, -1.5, 0], target=[0, 1, 0], up=[0, 0, 1]) (snell_window's camera)
    assert_mat(
        to_world(r#"<lookat origin="0, -1.5, 0" target="0, 1, 0" up="0, 0, 1"/>"#),
        [
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, -1.5],
            [0.0, 1.0, 0.0, 0.0],
        ],
        "lookat up z",
    );
    // Without `up`, Mitsuba takes the first tangent of coordinate_system(dir).
    assert_mat(
        to_world(r#"<lookat origin="0 0 0" target="1 2 3"/>"#),
        [
            [0.07928651, 0.9603568, 0.2672612, 0.0],
            [-0.841427, -0.07928651, 0.5345225, 0.0],
            [0.5345225, -0.2672612, 0.8017837, 0.0],
        ],
        "lookat no up",
    );
    assert_mat(
        to_world(r#"<lookat origin="1 1 1" target="1 1 -3"/>"#),
        [
            [0.0, 1.0, 0.0, 1.0],
            [1.0, 0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0, 1.0],
        ],
        "lookat no up, -z",
    );
    assert_mat(
        to_world(r#"<lookat origin="0 0 0" target="0 -1 0"/>"#),
        [
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 0.0],
            [-1.0, 0.0, 0.0, 0.0],
        ],
        "lookat no up, -y",
    );
}

#[test]
fn transform_composition_order() {
    // Each operation left-multiplies: translate then rotate = R · T.
    assert_mat(
        to_world(r#"<translate x="1"/><rotate y="1" angle="90"/>"#),
        [
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0, -1.0],
        ],
        "translate, rotate",
    );
    assert_mat(
        to_world(r#"<rotate y="1" angle="90"/><translate x="1"/>"#),
        [
            [0.0, 0.0, 1.0, 1.0],
            [0.0, 1.0, 0.0, 0.0],
            [-1.0, 0.0, 0.0, 0.0],
        ],
        "rotate, translate",
    );
    assert_mat(
        to_world(r#"<translate value="1 2 3"/><scale value="2"/>"#),
        [
            [2.0, 0.0, 0.0, 2.0],
            [0.0, 2.0, 0.0, 4.0],
            [0.0, 0.0, 2.0, 6.0],
        ],
        "translate, scale",
    );
    // scale 0.8 then the key light's lookat (mat_* scenes).
    assert_mat(
        to_world(
            r#"<scale value="0.8"/>
               <lookat origin="-2.5, 4.5, -2.0" target="0, 1, 0" up="0, 1, 0"/>"#,
        ),
        [
            [0.499756, 0.4609405, 0.421637, -2.5],
            [0.0, 0.5399588, -0.5902919, 4.5],
            [-0.6246951, 0.3687524, 0.3373096, -2.0],
        ],
        "scale, lookat",
    );
    // Partial attributes: translate defaults 0, scale defaults 1; a single value splats.
    assert_mat(
        to_world(r#"<scale y="3"/><translate z="2"/>"#),
        [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 3.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 2.0],
        ],
        "partial",
    );
    assert_mat(
        to_world(r#"<translate value="4"/><scale value="1, 2, 3"/>"#),
        [
            [1.0, 0.0, 0.0, 4.0],
            [0.0, 2.0, 0.0, 8.0],
            [0.0, 0.0, 3.0, 12.0],
        ],
        "splat translate",
    );
    assert_mat(
        to_world(r#"<matrix value="0 0 1 5  1 0 0 6  0 1 0 7  0 0 0 1"/>"#),
        [
            [0.0, 0.0, 1.0, 5.0],
            [1.0, 0.0, 0.0, 6.0],
            [0.0, 1.0, 0.0, 7.0],
        ],
        "matrix 4x4 row-major",
    );
    assert_mat(
        to_world(r#"<matrix value="1 2 3 4 5 6 7 8 9"/>"#),
        [
            [1.0, 2.0, 3.0, 0.0],
            [4.0, 5.0, 6.0, 0.0],
            [7.0, 8.0, 9.0, 0.0],
        ],
        "matrix 3x3",
    );
    assert_eq!(to_world(""), Mat4::IDENTITY);
}

// ---------------------------------------------------------------------------------------------
// Includes

struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> Self {
        let p = std::env::temp_dir().join(format!(
            "specula-xml-{name}-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(p.join("sub")).unwrap();
        TempDir(p)
    }
    fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.0.join(rel);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn include_splices_and_shares_defaults() {
    let d = TempDir::new("include");
    let main = d.write(
        "main.xml",
        r#"<scene version="3.0.0">
    <default name="r" value="2"/>
    <bsdf type="diffuse" id="first"/>
    <include filename="sub/a.xml"/>
    <shape type="sphere" id="last"/>
</scene>"#,
    );
    d.write(
        "sub/a.xml",
        r#"<scene version="3.0.0">
    <default name="r" value="5"/>
    <default name="inner" value="7"/>
    <shape type="sphere" id="a"><float name="radius" value="$r"/></shape>
    <include filename="b.xml"/>
    <include filename="top.xml"/>
</scene>"#,
    );
    // Relative to the including file's directory…
    d.write(
        "sub/b.xml",
        r#"<shape type="sphere" id="b" version="3.0.0"><float name="radius" value="$inner"/></shape>"#,
    );
    // …or, failing that, to the main scene's directory (as Mitsuba's file resolver does).
    d.write(
        "top.xml",
        r#"<scene version="3.0.0"><emitter type="constant" id="c"/></scene>"#,
    );
    let root = load_scene(&main, &[]).unwrap_or_else(|e| panic!("{e}"));
    let ids: Vec<&str> = root
        .children
        .iter()
        .map(|c| c.id.as_deref().unwrap())
        .collect();
    assert_eq!(ids, ["first", "a", "b", "c", "last"]);
    assert_eq!(
        root.children[1].float("radius", 0.0).unwrap(),
        2.0,
        "main's default wins"
    );
    assert_eq!(root.children[2].float("radius", 0.0).unwrap(), 7.0);
    assert!(
        root.children[1].loc.file.ends_with("a.xml"),
        "{}",
        root.children[1].loc.file
    );
    assert_eq!(root.children[1].loc.line, 4);
    // Overrides reach into included files, and may name parameters only they declare.
    let o = [("inner".to_string(), "9".to_string())];
    let root = load_scene(&main, &o).unwrap();
    assert_eq!(root.children[2].float("radius", 0.0).unwrap(), 9.0);
}

#[test]
fn include_errors() {
    let d = TempDir::new("include-err");
    let main = d.write(
        "main.xml",
        "<scene version=\"3.0.0\">\n    <include filename=\"sub/bad.xml\"/>\n</scene>",
    );
    let bad = d.write(
        "sub/bad.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n    <float name=\"radius\" \
         value=\"2x\"/>\n  </shape>\n</scene>",
    );
    let e = load_scene(&main, &[]).unwrap_err();
    let loc = e.loc.clone().unwrap();
    assert_eq!(loc.file, bad.display().to_string());
    assert_eq!((loc.line, loc.col), (3, 5));
    let text = e.to_string();
    assert!(
        text.contains("invalid value=\"2x\" in <float name=\"radius\">: expected a number"),
        "{text}"
    );
    assert!(
        text.contains(&format!("(in a file included at {}:2:5)", main.display())),
        "{text}"
    );

    d.write("sub/bad.xml", "<scene>\n</scene>");
    let e = load_scene(&main, &[]).unwrap_err().to_string();
    assert!(e.contains("missing 'version' attribute on <scene>"), "{e}");
    assert!(e.contains("bad.xml:1:1"), "{e}");

    d.write(
        "sub/bad.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n</scene>",
    );
    let e = load_scene(&main, &[]).unwrap_err().to_string();
    assert!(
        e.contains("bad.xml:3:") && e.contains("malformed XML"),
        "{e}"
    );

    let cyc = d.write(
        "cycle.xml",
        "<scene version=\"3.0.0\">\n  <include filename=\"cycle.xml\"/>\n</scene>",
    );
    let e = load_scene(&cyc, &[]).unwrap_err().to_string();
    assert!(e.contains("include cycle"), "{e}");
    assert!(e.contains("cycle.xml:2:3"), "{e}");

    let e = parse(&scene(r#"<include filename="nope.xml"/>"#))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("test.xml:2:1: included file 'nope.xml' not found"),
        "{e}"
    );

    let e = load_scene(&d.0.join("missing.xml"), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing.xml"), "{e}");
}

// ---------------------------------------------------------------------------------------------
// Mitsuba 0.6 scenes

#[test]
fn snake_case_matches_mitsuba() {
    // Outputs observed from Mitsuba 3.9.1's upgrade (the names it reports as unreferenced).
    for (old, new) in [
        ("maxDepth", "max_depth"),
        ("intIOR", "int_ior"),
        ("extIOR", "ext_ior"),
        ("specularReflectance", "specular_reflectance"),
        ("toWorld", "to_world"),
        ("fooBarBAZ", "foo_bar_baz"),
        ("fooBar2Baz", "foo_bar2Baz"),
        ("XYZabc", "XYZabc"),
        ("aBCdEF", "a_bcd_ef"),
        ("a2B", "a2B"),
        ("aB2C", "a_b2C"),
        ("fooBARbaz", "foo_barbaz"),
        ("aB_C", "a_b_C"),
        ("a__B", "a__B"),
        ("aBcD", "a_bc_d"),
        ("max_depth", "max_depth"),
    ] {
        assert_eq!(to_snake_case(old), new, "{old}");
    }
}

#[test]
fn upgrades_version_0_6_scenes() {
    let s = r#"<scene version="0.6.0">
    <default name="sampleCount" value="16"/>
    <integrator type="path"><integer name="maxDepth" value="3"/></integrator>
    <sensor type="perspective">
        <string name="fovAxis" value="smaller"/>
        <transform name="toWorld">
            <lookAt origin="0, 0, 4.1" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <sampler type="independent"><integer name="sampleCount" value="$sampleCount"/></sampler>
    </sensor>
    <bsdf type="dielectric" id="glass">
        <float name="intIOR" value="1.7"/>
        <float name="extIOR" value="1.1"/>
        <rgb name="specularReflectance" value="0.9"/>
    </bsdf>
    <bsdf type="diffuse" id="d"><rgb name="diffuseReflectance" value="0.1 0.2 0.3"/></bsdf>
    <bsdf type="diffuse" id="t">
        <texture type="bitmap" name="diffuseReflectance">
            <string name="filename" value="grid.png"/>
            <float name="uscale" value="2"/>
            <float name="vscale" value="3"/>
            <float name="uoffset" value="0.1"/>
        </texture>
    </bsdf>
</scene>"#;
    let root = parse(s).unwrap();
    let int = &root.children[0];
    assert_eq!(int.int("max_depth", 0).unwrap(), 3);
    let sensor = &root.children[1];
    assert_eq!(sensor.string("fov_axis", "").unwrap(), "smaller");
    assert_mat(
        sensor.transform("to_world").unwrap().unwrap(),
        [
            [-1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0, 4.1],
        ],
        "upgraded lookAt",
    );
    assert_eq!(sensor.children[0].int("sample_count", 0).unwrap(), 16);
    let glass = &root.children[2];
    assert_eq!(glass.float("int_ior", 0.0).unwrap(), 1.7);
    assert_eq!(glass.float("ext_ior", 0.0).unwrap(), 1.1);
    assert_eq!(
        glass.rgb("specular_reflectance", [0.0; 3]).unwrap(),
        [0.9; 3]
    );
    glass.check_unused(&[]).unwrap();
    // diffuse: diffuse_reflectance → reflectance (Mitsuba does this too).
    assert_eq!(
        root.children[3].rgb("reflectance", [0.0; 3]).unwrap(),
        [0.1, 0.2, 0.3]
    );
    let tex = root.children[4].child_named("reflectance").unwrap();
    // uscale/vscale/uoffset/voffset → to_uv = scale · translate; Mitsuba prints the 3×3
    // [[2, 0, 0.2], [0, 3, 0], [0, 0, 1]] for these values.
    let names: Vec<&str> = tex.props.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["filename", "to_uv"]);
    assert_mat(
        tex.transform("to_uv").unwrap().unwrap(),
        [
            [2.0, 0.0, 0.0, 0.2],
            [0.0, 3.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ],
        "to_uv",
    );
    // A version 3 scene is not upgraded.
    let root = parse(&scene(
        r#"<integrator type="path"><integer name="maxDepth" value="3"/></integrator>"#,
    ))
    .unwrap();
    assert!(root.children[0].has("maxDepth"));
    let e = parse(&scene(
        r#"<sensor type="perspective"><transform name="to_world"><lookAt origin="0 0 1" target="0 0 0"/></transform></sensor>"#,
    ))
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(
            "unexpected <lookAt> inside <transform> (in a version 3 scene it is spelled <lookat>)"
        ),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------------
// Malformed input

#[test]
fn malformed_inputs_give_located_errors() {
    // (scene body, expected message text, text at the start of the element the error points at;
    // its last occurrence)
    let cases: &[(&str, &str, &str)] = &[
        (r#"<shape type="sphere"><foo name="x" value="1"/></shape>"#, "unknown element <foo>; valid elements: shape, bsdf", "<foo"),
        (r#"<shape id="s"/>"#, "missing required attribute 'type' in <shape>", "<shape"),
        (r#"<shape type="s"><float name="radius" value="0.5x"/></shape>"#, "invalid value=\"0.5x\" in <float name=\"radius\">: expected a number", "<float"),
        (r#"<shape type="s"><float name="radius" value="nan"/></shape>"#, "expected a number", "<float"),
        (r#"<shape type="s"><float name="radius"/></shape>"#, "missing required attribute 'value' in <float>", "<float"),
        (r#"<shape type="s"><float value="1"/></shape>"#, "missing required attribute 'name' in <float>", "<float"),
        (r#"<shape type="s"><integer name="n" value="2.5"/></shape>"#, "invalid value=\"2.5\" in <integer name=\"n\">: expected an integer", "<integer"),
        (r#"<shape type="s"><boolean name="b" value="yes"/></shape>"#, "expected \"true\" or \"false\"", "<boolean"),
        (r#"<shape type="s"><rgb name="c" value="0.1 0.2"/></shape>"#, "expected 1 or 3 numbers, found 2", "<rgb"),
        (r#"<shape type="s"><rgb name="c" value="0.1, abc, 0.3"/></shape>"#, "'abc' is not a number", "<rgb"),
        (r#"<shape type="s"><spectrum name="c" value="400:0.1, 400:0.5"/></shape>"#, "invalid value in <spectrum name=\"c\">: wavelengths must increase strictly (400 nm is followed by 400 nm)", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" value="400:0.1, 500"/></shape>"#, "'500' is not a wavelength:value pair", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" value="400:0.1, 500:nan"/></shape>"#, "'500:nan' is not a wavelength:value pair of numbers", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" value="400:0.1"/></shape>"#, "at least two wavelength:value pairs, found 1", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" value=""/></shape>"#, "expected one number or wavelength:value pairs", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" value="0.1, 0.5"/></shape>"#, "expected one number or wavelength:value pairs", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c"/></shape>"#, "needs either a 'value' or a 'filename' attribute", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" value="1" filename="x.spd"/></shape>"#, "needs either a 'value' or a 'filename' attribute (not both)", "<spectrum"),
        (r#"<shape type="s"><spectrum name="c" filename="no_such_file.spd"/></shape>"#, "spectrum file 'no_such_file.spd' not found", "<spectrum"),
        (r#"<shape type="s"><spectrum type="blackbody" name="c"/></shape>"#, "spectrum 'blackbody' needs 'temperature'", "<spectrum"),
        (r#"<shape type="s"><spectrum type="blackbody" name="c"><float name="temperature" value="-3"/></spectrum></shape>"#, "the temperature must be positive", "<spectrum"),
        (r#"<shape type="s"><spectrum type="blackbody" name="c"><float name="temperature" value="5000"/><float name="scale" value="2"/></spectrum></shape>"#, "unknown parameter 'scale' for spectrum 'blackbody'", "<float name=\"scale\""),
        (r#"<shape type="s"><spectrum type="d65" name="c"><float name="color" value="2"/></spectrum></shape>"#, "parameter 'color' of spectrum 'd65': expected rgb, found float", "<float"),
        (r#"<shape type="s"><spectrum type="irregular" name="c"><string name="wavelengths" value="400 500"/><string name="values" value="1"/></spectrum></shape>"#, "spectrum 'irregular': 2 wavelengths but 1 values", "<spectrum"),
        (r#"<shape type="s"><spectrum type="regular" name="c"><float name="wavelength_min" value="400"/><float name="wavelength_max" value="700"/><string name="values" value="1, x"/></spectrum></shape>"#, "'values' of spectrum 'regular': 'x' is not a number", "<spectrum"),
        (r#"<shape type="s"><spectrum type="rainbow" name="c"/></shape>"#, "spectrum type 'rainbow' is not supported", "<spectrum"),
        (r#"<shape type="s"><spectrum type="uniform" name="c"><bsdf type="diffuse"/></spectrum></shape>"#, "<bsdf> cannot be nested in <spectrum type=\"uniform\">", "<bsdf"),
        (r#"<shape type="s"><point name="p"/></shape>"#, "<point name=\"p\"> needs value=", "<point"),
        (r#"<shape type="s"><point name="p" value="1 2 3" x="1"/></shape>"#, "cannot mix the 'value' attribute with x=/y=/z=", "<point"),
        (r#"<shape type="s"><float name="a" value="1" foo="2"/></shape>"#, "unexpected attribute 'foo' in <float>; valid attributes: name, value", "<float"),
        (r#"<shape type="s"><float name="r" value="1"/>
<float name="r" value="2"/></shape>"#, "duplicate parameter 'r' in shape 's' (first given at test.xml:2:17)", "<float name=\"r\" value=\"2\""),
        (r#"<bsdf type="diffuse"><rgb name="reflectance" value="1"/><texture type="checkerboard" name="reflectance"/></bsdf>"#, "duplicate parameter 'reflectance'", "<texture"),
        (r#"<bsdf type="diffuse" id="w"/>
<bsdf type="diffuse" id="w"/>"#, "duplicate id 'w' (first defined at test.xml:2:1)", "<bsdf"),
        (r#"<shape type="s"><float name="radius" value="$radius"/></shape>"#, "undefined parameter '$radius'", "<float"),
        (r#"<shape type="s"><string name="f" value="cost: 5$"/></shape>"#, "a parameter name must follow '$'", "<string"),
        (r#"<default name="a"/>"#, "missing required attribute 'value' in <default>", "<default"),
        (r#"<shape type="s"><translate x="1"/></shape>"#, "<translate> is only valid inside <transform>", "<translate"),
        (r#"<shape type="s"><transform><translate x="1"/></transform></shape>"#, "missing required attribute 'name' in <transform>", "<transform"),
        (r#"<shape type="s"><transform name="to_world"><float name="x" value="1"/></transform></shape>"#, "unexpected <float> inside <transform>; valid elements: translate, rotate, scale, lookat, matrix", "<float"),
        (r#"<shape type="s"><transform name="to_world"><rotate angle="90"/></transform></shape>"#, "<rotate> needs a non-zero axis", "<rotate"),
        (r#"<shape type="s"><transform name="to_world"><rotate x="1"/></transform></shape>"#, "missing required attribute 'angle' in <rotate>", "<rotate"),
        (r#"<shape type="s"><transform name="to_world"><rotate x="1" angle="ninety"/></transform></shape>"#, "invalid angle=\"ninety\" in <rotate>: expected a number", "<rotate"),
        (r#"<shape type="s"><transform name="to_world"><lookat origin="0 1 0" target="0 2 0" up="0 1 0"/></transform></shape>"#, "invalid <lookat>: the up vector is zero or parallel", "<lookat"),
        (r#"<shape type="s"><transform name="to_world"><lookat origin="1 1 1" target="1 1 1"/></transform></shape>"#, "invalid <lookat>: origin and target coincide", "<lookat"),
        (r#"<shape type="s"><transform name="to_world"><lookat origin="1 1 1"/></transform></shape>"#, "missing required attribute 'target' in <lookat>", "<lookat"),
        (r#"<shape type="s"><transform name="to_world"><matrix value="1 2 3 4 5 6 7 8"/></transform></shape>"#, "expected 16 (4x4) or 9 (3x3) numbers in row-major order, found 8", "<matrix"),
        (r#"<shape type="s"><transform name="to_world"><scale value="1 2"/></transform></shape>"#, "invalid value=\"1 2\" in <scale>: expected 1 or 3 numbers, found 2", "<scale"),
        (r#"<shape type="s"><transform name="to_world"><scale value="2" x="1"/></transform></shape>"#, "cannot mix", "<scale"),
        (r#"<shape type="s"><transform name="to_world"><rotate value="1 0 0" axis="1 0 0" angle="3"/></transform></shape>"#, "cannot have both 'value' and 'axis'", "<rotate"),
        (r#"<shape type="s"><ref name="bsdf"/></shape>"#, "missing required attribute 'id' in <ref>", "<ref"),
        (r#"<scene version="3.0.0"/>"#, "<scene> can only be the root element", "<scene version=\"3.0.0\"/>"),
        (r#"<shape type="s"><srgb name="c" value="1 0 0"/></shape>"#, "<srgb> (a Mitsuba 0.6 element) is not supported", "<srgb"),
        (r#"<shape type="s" version="3.0.0"/>"#, "unexpected attribute 'version' in <shape>", "<shape"),
    ];
    for (body, expected, anchor) in cases {
        let text = scene(body);
        let err = match parse(&text) {
            Ok(_) => panic!("no error for {body}"),
            Err(e) => e,
        };
        let at = text
            .rfind(anchor)
            .unwrap_or_else(|| panic!("anchor {anchor} not in {body}"));
        let line = text[..at].matches('\n').count() + 1;
        let col = at - text[..at].rfind('\n').map_or(0, |i| i + 1) + 1;
        let msg = err.to_string();
        assert!(
            msg.contains(expected),
            "{body}\n  expected: {expected}\n  got: {msg}"
        );
        assert!(
            msg.starts_with(&format!("test.xml:{line}:{col}: ")),
            "{body}\n  expected location {line}:{col}\n  got: {msg}"
        );
    }
}

#[test]
fn malformed_documents() {
    let cases: &[(&str, &str, &str)] = &[
        (
            "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>\n",
            "malformed XML",
            "test.xml:3:",
        ),
        (
            "<scene version=\"3.0.0\">\n  <shape type=\"sphere\" type=\"x\"/>\n</scene>\n",
            "malformed XML",
            "test.xml:2:",
        ),
        ("", "malformed XML", "test.xml:1:1"),
        (
            "<scene>\n</scene>",
            "missing 'version' attribute on <scene>, the root element of the scene",
            "test.xml:1:1",
        ),
        (
            "<scene version=\"3.0\"/>",
            "invalid version=\"3.0\": expected major.minor.patch",
            "test.xml:1:1",
        ),
        (
            "<!-- c -->\n<shape type=\"sphere\" version=\"3.0.0\"/>",
            "the root element must be <scene",
            "test.xml:2:1",
        ),
        (
            "<scene version=\"3.0.0\" type=\"x\"/>",
            "only \"scene\" is valid",
            "test.xml:1:1",
        ),
    ];
    for (text, expected, loc) in cases {
        let msg = parse(text).map(|_| ()).unwrap_err().to_string();
        assert!(
            msg.contains(expected),
            "{text}\n  expected: {expected}\n  got: {msg}"
        );
        assert!(
            msg.starts_with(loc),
            "{text}\n  expected location {loc}\n  got: {msg}"
        );
    }
    // Text and comments between elements are ignored, as in Mitsuba.
    let root =
        parse("<?xml version=\"1.0\"?>\n<scene version=\"3.0.0\"><!-- x -->hello</scene>").unwrap();
    assert!(root.children.is_empty() && root.props.is_empty());
}
