//! Scene-level behaviour of the surface helpers: `mesh_attribute` is checked against the shapes
//! it is used on when the scene loads, and `bumpmap` refuses height fields without a gradient,
//! each with an error naming file:line:col.

use specula_render::scene::Scene;
use std::path::Path;

fn err(body: &str) -> String {
    match load(body) {
        Ok(_) => panic!("loaded: {body}"),
        Err(e) => e,
    }
}

fn load(body: &str) -> Result<Scene, String> {
    let xml = format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>
</sensor>
{body}
</scene>"#
    );
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    Scene::from_xml_str(&xml, "test.xml", &dir, &[]).map_err(|e| e.to_string())
}

const ATTR_BSDF: &str = r#"<bsdf type="diffuse" id="m">
<texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture>
</bsdf>"#;

#[test]
fn mesh_attribute_is_checked_against_its_shapes() {
    // an OBJ has no attributes: the error names the texture and the shape
    let e = err(&format!(
        r#"{ATTR_BSDF}
<shape type="obj"><string name="filename" value="deriv_quad.obj"/><ref id="m"/></shape>"#
    ));
    assert!(
        e.starts_with("test.xml:6:")
            && e.contains("the shape at test.xml:8:1 has no such attribute (it has: none)"),
        "{e}"
    );
    let e = err(&format!(
        r#"{ATTR_BSDF}<shape type="sphere"><ref id="m"/></shape>"#
    ));
    assert!(e.contains("is not a mesh"), "{e}");
    // a PLY with vertex colours loads, and the texture reads them
    let s = load(&format!(
        r#"{ATTR_BSDF}<shape type="ply"><string name="filename" value="colored.ply"/><ref id="m"/></shape>"#
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let data = s.geometry[0].surface_data().unwrap();
    let c = data
        .attribute("vertex_color", 0, glam::Vec2::new(0.25, 0.5))
        .unwrap();
    // b0 = 0.25: 0.25·(1, 0, 0) + 0.25·(0, 1, 0) + 0.5·(0, 0, 1)
    assert!(
        (0..3).all(|i| (c[i] - [0.25, 0.25, 0.5][i]).abs() < 1e-6),
        "{c:?}"
    );
    // names must start with vertex_ or face_
    let e = err(
        r#"<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="color"/></texture></bsdf>"#,
    );
    assert!(e.contains("must start with 'vertex_' or 'face_'"), "{e}");
}

#[test]
fn bumpmap_needs_a_gradient_and_one_nested_bsdf() {
    let e = err(
        r#"<bsdf type="bumpmap"><texture type="checkerboard" name="h"/><bsdf type="diffuse"/></bsdf>"#,
    );
    assert!(
        e.starts_with("test.xml:") && e.contains("no texture-space gradient"),
        "{e}"
    );
    let e = err(r#"<bsdf type="mask"><float name="opacity" value="0.5"/></bsdf>"#);
    assert!(e.contains("needs exactly one nested BSDF, got 0"), "{e}");
    let e = err(r#"<bsdf type="normalmap"><bsdf type="diffuse"/></bsdf>"#);
    assert!(e.contains("needs parameter 'normalmap'"), "{e}");
    // twosided refuses the null lobe's transmission, as Mitsuba does
    let e = err(r#"<bsdf type="twosided"><bsdf type="null"/></bsdf>"#);
    assert!(e.contains("cannot nest 'null'"), "{e}");
}
