//! Files named in a scene resolve like Mitsuba's: relative to the file that names them (an
//! included file), then to the main scene's directory; a missing one is a located error.

use specula_render::scene::Scene;

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>"#;

#[test]
fn included_files_resolve_their_own_paths() {
    let dir = std::env::temp_dir().join(format!("specula-scene-files-{}", std::process::id()));
    let sub = dir.join("parts");
    std::fs::create_dir_all(&sub).unwrap();
    specula_render::image_io::write_png(&sub.join("tex.png"), 2, 2, &[0.5; 12]).unwrap();
    std::fs::write(
        sub.join("part.xml"),
        r#"<scene version="3.0.0"><shape type="sphere"><bsdf type="diffuse">
             <texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/></texture>
           </bsdf></shape></scene>"#,
    )
    .unwrap();
    std::fs::write(
        dir.join("main.xml"),
        format!(r#"<scene version="3.0.0">{SENSOR}<include filename="parts/part.xml"/></scene>"#),
    )
    .unwrap();
    let s = Scene::load(&dir.join("main.xml"), &[]);
    assert!(s.is_ok(), "{:?}", s.err());

    // the same texture name from the main file does not exist beside it
    std::fs::write(
        dir.join("bad.xml"),
        format!(
            r#"<scene version="3.0.0">{SENSOR}
<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/></texture></bsdf></shape>
</scene>"#
        ),
    )
    .unwrap();
    let err = Scene::load(&dir.join("bad.xml"), &[])
        .err()
        .expect("missing texture accepted")
        .to_string();
    assert!(err.contains("bad.xml:") && err.contains("tex.png"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
