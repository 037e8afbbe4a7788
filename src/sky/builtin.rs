//! The photographic skies shipped in the binary (`assets/skies/`, CC0 Poly
//! Haven HDRIs; licence and source beside them), named by
//! `SkyImageSource::Builtin` (the names and descriptions are
//! `preset::BUILTIN_SKIES`).

/// The file name (for the format and messages) and bytes of built-in sky `name`.
pub fn sky(name: &str) -> Option<(&'static str, &'static [u8])> {
    Some(match name {
        "quarry_01" => (
            "quarry_01_512.hdr",
            include_bytes!("../../assets/skies/quarry_01_512.hdr"),
        ),
        "venice_sunset" => (
            "venice_sunset_512.hdr",
            include_bytes!("../../assets/skies/venice_sunset_512.hdr"),
        ),
        "forest" => (
            "forest.exr",
            include_bytes!("../../assets/skies/forest.exr"),
        ),
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_listed_builtin_sky_has_its_image() {
        for (name, _) in crate::preset::BUILTIN_SKIES {
            let (file, bytes) = super::sky(name).expect("listed sky is built in");
            let radiance = file.ends_with(".hdr") && bytes.starts_with(b"#?RADIANCE");
            let exr = file.ends_with(".exr") && bytes.starts_with(&[0x76, 0x2f, 0x31, 0x01]);
            assert!(radiance || exr, "{name}");
        }
        assert!(super::sky("nope").is_none());
    }
}
