//! The looks of the seven named environments (the paper's Unity skyboxes).

use crate::preset::EnvironmentName;

/// What covers the ground plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ground {
    Grass = 0,
    Snow = 1,
    Water = 2,
    Road = 3,
}

/// A silhouette band on the horizon.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Silhouette {
    None = 0,
    Hills = 1,
    Mountains = 2,
    Skyline = 3,
    TreeLine = 4,
}

/// The look of a procedural environment; the sun, turbidity and clouds are its defaults.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentStyle {
    pub sun_elevation_deg: f64,
    pub sun_azimuth_deg: f64,
    pub turbidity: f64,
    pub cloud_cover: f64,
    pub ground: Ground,
    /// Two linear albedos the ground pattern mixes.
    pub ground_albedo: [[f32; 3]; 2],
    pub far: Silhouette,
    /// Angular height of the far silhouette, degrees.
    pub far_height_deg: f32,
    pub far_albedo: [f32; 3],
    /// Snow on the far silhouette's upper part.
    pub snow_caps: bool,
    pub near: Silhouette,
    pub near_height_deg: f32,
    pub near_albedo: [f32; 3],
}

impl EnvironmentName {
    /// The environment's look and default sun.
    pub fn style(self) -> EnvironmentStyle {
        const GRASS: [[f32; 3]; 2] = [[0.07, 0.16, 0.035], [0.16, 0.22, 0.06]];
        let base = EnvironmentStyle {
            sun_elevation_deg: 50.0,
            sun_azimuth_deg: 135.0,
            turbidity: 2.5,
            cloud_cover: 0.15,
            ground: Ground::Grass,
            ground_albedo: GRASS,
            far: Silhouette::Hills,
            far_height_deg: 1.2,
            far_albedo: [0.10, 0.14, 0.10],
            snow_caps: false,
            near: Silhouette::None,
            near_height_deg: 0.0,
            near_albedo: [0.03, 0.06, 0.03],
        };
        match self {
            Self::Daytime => base,
            Self::Sunset => EnvironmentStyle {
                sun_elevation_deg: 4.0,
                sun_azimuth_deg: 250.0,
                turbidity: 4.5,
                cloud_cover: 0.35,
                ground_albedo: [[0.05, 0.08, 0.03], [0.10, 0.10, 0.05]],
                far_height_deg: 1.6,
                near: Silhouette::TreeLine,
                near_height_deg: 0.8,
                ..base
            },
            Self::BeautifulPasture => EnvironmentStyle {
                sun_elevation_deg: 35.0,
                sun_azimuth_deg: 200.0,
                turbidity: 2.2,
                cloud_cover: 0.4,
                ground_albedo: [[0.08, 0.22, 0.03], [0.22, 0.30, 0.05]],
                far_height_deg: 4.0,
                far_albedo: [0.08, 0.18, 0.06],
                near: Silhouette::TreeLine,
                near_height_deg: 0.6,
                ..base
            },
            Self::SnowyBridge => EnvironmentStyle {
                sun_elevation_deg: 20.0,
                sun_azimuth_deg: 160.0,
                turbidity: 3.0,
                cloud_cover: 0.55,
                ground: Ground::Snow,
                ground_albedo: [[0.70, 0.74, 0.80], [0.85, 0.87, 0.90]],
                far: Silhouette::Mountains,
                far_height_deg: 9.0,
                far_albedo: [0.18, 0.2, 0.24],
                snow_caps: true,
                near: Silhouette::TreeLine,
                near_height_deg: 1.0,
                near_albedo: [0.02, 0.04, 0.03],
            },
            Self::SmallHarbour => EnvironmentStyle {
                sun_elevation_deg: 30.0,
                sun_azimuth_deg: 100.0,
                turbidity: 3.5,
                cloud_cover: 0.3,
                ground: Ground::Water,
                ground_albedo: [[0.01, 0.03, 0.04], [0.02, 0.05, 0.06]],
                far: Silhouette::Skyline,
                far_height_deg: 2.0,
                far_albedo: [0.25, 0.22, 0.2],
                ..base
            },
            Self::Tellsplatte => EnvironmentStyle {
                sun_elevation_deg: 40.0,
                sun_azimuth_deg: 120.0,
                turbidity: 2.0,
                cloud_cover: 0.25,
                ground: Ground::Water,
                ground_albedo: [[0.01, 0.04, 0.05], [0.02, 0.06, 0.07]],
                far: Silhouette::Mountains,
                far_height_deg: 22.0,
                far_albedo: [0.10, 0.12, 0.10],
                snow_caps: true,
                near: Silhouette::None,
                ..base
            },
            Self::CountryRoad => EnvironmentStyle {
                sun_elevation_deg: 55.0,
                sun_azimuth_deg: 60.0,
                turbidity: 2.8,
                cloud_cover: 0.2,
                ground: Ground::Road,
                ground_albedo: [[0.09, 0.15, 0.04], [0.22, 0.20, 0.08]],
                far_height_deg: 1.0,
                near: Silhouette::TreeLine,
                near_height_deg: 1.4,
                ..base
            },
        }
    }
}
