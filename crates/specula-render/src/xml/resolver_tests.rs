//! Tests of the file resolver (`<path>`, `filename` parameters, includes), `<alias>`, and the
//! inlining of top-level definitions (`<sampler id=…>` used through `<ref>`). Mitsuba 3.9.1
//! (`scalar_rgb`) was probed for the rules: a relative `<path>` is relative to the file that
//! declares it and must exist; includes and files are searched in the `<path>` folders.

use super::*;
use std::path::{Path, PathBuf};

struct Dir(PathBuf);

impl Dir {
    fn new(name: &str) -> Self {
        let p = std::env::temp_dir().join(format!(
            "specula-resolver-{name}-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        Dir(p)
    }
    fn write(&self, rel: &str, text: &str) -> PathBuf {
        let p = self.0.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn filename_of(n: &Node) -> String {
    match &n.prop("filename").unwrap().value {
        PropValue::Str(s) => s.clone(),
        v => panic!("filename is {v:?}"),
    }
}

#[test]
fn search_paths_resolve_includes_and_files() {
    let d = Dir::new("paths");
    // Mitsuba's docs layout: docs/scenes/X.xml with <path value="../../common"/>
    d.write("common/meshes/m.obj", "v 0 0 0\n");
    d.write("common/textures/t.png", "not really a png");
    d.write(
        "docs/scenes/include/inc.xml",
        r#"<scene version="3.0.0">
    <shape type="obj" id="s"><string name="filename" value="meshes/m.obj"/></shape>
    <texture type="bitmap" id="t"><string name="filename" value="textures/t.png"/></texture>
</scene>"#,
    );
    let main = d.write(
        "docs/scenes/main.xml",
        r#"<scene version="3.0.0">
    <path value="../../common"/>
    <include filename="include/inc.xml"/>
    <shape type="ply"><string name="filename" value="missing.ply"/></shape>
</scene>"#,
    );
    let root = load_scene(&main, &[]).unwrap();
    let mesh = filename_of(&root.children[0]);
    let tex = filename_of(&root.children[1]);
    assert!(Path::new(&mesh).is_absolute(), "{mesh}");
    assert!(mesh.ends_with("common/meshes/m.obj"), "{mesh}");
    assert!(Path::new(&mesh).exists());
    assert!(tex.ends_with("common/textures/t.png"), "{tex}");
    // a file found nowhere is left as written, for the plugin to report
    assert_eq!(filename_of(&root.children[2]), "missing.ply");
}

#[test]
fn latest_search_path_wins_and_relative_to_declaring_file() {
    let d = Dir::new("order");
    d.write("a/f.obj", "a");
    d.write("b/f.obj", "b");
    // the include lives in sub/; its <path value="../b"/> is relative to sub/
    d.write(
        "sub/inc.xml",
        r#"<scene version="3.0.0"><path value="../b"/></scene>"#,
    );
    let main = d.write(
        "main.xml",
        r#"<scene version="3.0.0">
    <path value="a"/>
    <shape type="obj"><string name="filename" value="f.obj"/></shape>
    <include filename="sub/inc.xml"/>
    <shape type="obj"><string name="filename" value="f.obj"/></shape>
</scene>"#,
    );
    let root = load_scene(&main, &[]).unwrap();
    let first = filename_of(&root.children[0]);
    let second = filename_of(&root.children[1]);
    assert!(first.ends_with("a/f.obj"), "{first}");
    assert!(second.ends_with("b/f.obj"), "{second}");
}

#[test]
fn search_path_in_an_include_falls_back_to_the_scene_folder() {
    // Mitsuba's docs scenes: include/emitter_scene.xml says <path value="../../common"/>,
    // which exists relative to the main scene's folder but not to the include's
    let d = Dir::new("fallback");
    d.write("common/m.obj", "v 0 0 0\n");
    d.write(
        "docs/scenes/include/inc.xml",
        r#"<scene version="3.0.0"><path value="../../common"/>
    <shape type="obj"><string name="filename" value="m.obj"/></shape></scene>"#,
    );
    let main = d.write(
        "docs/scenes/main.xml",
        r#"<scene version="3.0.0"><include filename="include/inc.xml"/></scene>"#,
    );
    let root = load_scene(&main, &[]).unwrap();
    assert!(filename_of(&root.children[0]).ends_with("common/m.obj"));
}

#[test]
fn missing_search_path_is_a_located_error() {
    let d = Dir::new("missing");
    let main = d.write(
        "main.xml",
        "<scene version=\"3.0.0\">\n    <path value=\"nowhere\"/>\n</scene>",
    );
    let e = load_scene(&main, &[]).unwrap_err().to_string();
    assert!(e.contains("main.xml:2:5"), "{e}");
    assert!(
        e.contains("folder not found") && e.contains("nowhere"),
        "{e}"
    );
    let e = load_scene(
        &d.write("bad.xml", "<scene version=\"3.0.0\"><path/></scene>"),
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("missing required attribute 'value'"), "{e}");
}

#[test]
fn top_level_sampler_film_and_rfilter_are_inlined_where_referenced() {
    let text = r#"<scene version="3.0.0">
    <rfilter type="box" id="f"/>
    <film type="hdrfilm" id="film"><integer name="width" value="32"/><ref id="f"/></film>
    <sampler type="stratified" id="my_sampler"><integer name="sample_count" value="16"/></sampler>
    <sensor type="perspective">
        <ref id="my_sampler"/>
        <ref id="film"/>
    </sensor>
</scene>"#;
    let root = parse_scene_str(text, "t.xml", Path::new("."), &[]).unwrap();
    // the definitions leave the top level
    assert_eq!(root.children.len(), 1);
    let sensor = &root.children[0];
    assert_eq!(sensor.tag, "sensor");
    let tags: Vec<(&str, &str)> = sensor
        .children
        .iter()
        .map(|c| (c.tag.as_str(), c.plugin_type.as_str()))
        .collect();
    assert_eq!(tags, [("sampler", "stratified"), ("film", "hdrfilm")]);
    assert_eq!(sensor.children[0].int("sample_count", 0).unwrap(), 16);
    // a ref nested in an inlined definition is inlined too
    let film = &sensor.children[1];
    assert_eq!(film.children[0].tag, "rfilter");
    assert_eq!(film.children[0].plugin_type, "box");
    // the copy keeps the declaration's location
    assert_eq!(film.loc.line, 3);
}

#[test]
fn aliases_name_the_same_plugin() {
    let text = r#"<scene version="3.0.0">
    <bsdf type="diffuse" id="a"/>
    <alias id="a" as="b"/>
    <alias id="b" as="c"/>
    <shape type="sphere"><ref id="c"/></shape>
</scene>"#;
    let root = parse_scene_str(text, "t.xml", Path::new("."), &[]).unwrap();
    assert_eq!(root.children[1].children[0].id.as_deref(), Some("a"));
    let e = parse_scene_str(
        "<scene version=\"3.0.0\">\n<alias id=\"zz\" as=\"y\"/></scene>",
        "t.xml",
        Path::new("."),
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("t.xml:2:1") && e.contains("'zz'"), "{e}");
    let e = parse_scene_str(
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"a\"/><bsdf type=\"diffuse\" id=\"b\"/>\n<alias id=\"a\" as=\"b\"/></scene>",
        "t.xml",
        Path::new("."),
        &[],
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("already defined"), "{e}");
}

#[test]
fn forward_references_are_reordered() {
    // Mitsuba's integrator_depth_*.xml reference an area emitter declared at the end
    let text = r#"<scene version="3.0.0">
    <shape type="sphere"><ref id="m"/><ref id="light"/></shape>
    <bsdf type="twosided" id="m"><ref id="inner"/></bsdf>
    <bsdf type="diffuse" id="inner"/>
    <emitter type="area" id="light"><rgb name="radiance" value="1"/></emitter>
    <emitter type="point" id="p"/>
</scene>"#;
    let root = parse_scene_str(text, "t.xml", Path::new("."), &[]).unwrap();
    let order: Vec<String> = root
        .children
        .iter()
        .map(|c| format!("{}:{}", c.tag, c.id.as_deref().unwrap_or("-")))
        .collect();
    assert_eq!(order, ["bsdf:inner", "bsdf:m", "shape:-", "emitter:p"]);
    // the area emitter moved into the shape that references it
    let shape = &root.children[2];
    assert_eq!(shape.children[1].tag, "emitter");
    assert_eq!(shape.children[1].plugin_type, "area");
    let cyc = r#"<scene version="3.0.0">
    <bsdf type="twosided" id="a"><ref id="b"/></bsdf>
    <bsdf type="twosided" id="b"><ref id="a"/></bsdf>
</scene>"#;
    let e = parse_scene_str(cyc, "t.xml", Path::new("."), &[])
        .unwrap_err()
        .to_string();
    assert!(e.contains("depends on it in turn"), "{e}");
}
