//! The 68 MPEG-4 facial animation parameters (ISO/IEC 14496-2 annex C) and the FAP units
//! (FAPU) that scale them. A FAP value is an integer count of FAPU0/1024 (or of 1e-5 rad for
//! angles), so the same stream drives faces of any size.
//!
//! The table is `data/candide3/mpeg4_faps.tsv` in code form. CANDIDE-3 stores a unit
//! direction per FAP unit; this module says how far one FAP count moves along it.

use glam::Vec3;

/// The FAP units of MPEG-4: lengths measured on the neutral face, plus the angle unit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "UPPERCASE")]
pub enum Fapu {
    /// Mouth-nose separation.
    Mns,
    /// Mouth width.
    Mw,
    /// Eye-nose separation.
    Ens,
    /// Eye separation (pupil to pupil).
    Es,
    /// Iris diameter (upper to lower eyelid in the neutral face).
    Irisd,
    /// Angle unit: 1e-5 rad.
    Au,
}

impl Fapu {
    pub fn name(self) -> &'static str {
        match self {
            Fapu::Mns => "MNS",
            Fapu::Mw => "MW",
            Fapu::Ens => "ENS",
            Fapu::Es => "ES",
            Fapu::Irisd => "IRISD",
            Fapu::Au => "AU",
        }
    }

    /// Parses a FAPU name as written in `.wfm` comments (`# MNS`).
    pub fn parse(text: &str) -> Option<Fapu> {
        match text.trim().to_ascii_uppercase().as_str() {
            "MNS" => Some(Fapu::Mns),
            "MW" => Some(Fapu::Mw),
            "ENS" => Some(Fapu::Ens),
            "ES" => Some(Fapu::Es),
            "IRISD" => Some(Fapu::Irisd),
            "AU" => Some(Fapu::Au),
            _ => None,
        }
    }
}

/// One row of the MPEG-4 FAP table.
#[derive(Debug, Clone, Copy)]
pub struct FapInfo {
    /// FAP number, 1..=68.
    pub number: u8,
    /// The standard's name (`open_jaw`).
    pub name: &'static str,
    /// The unit its values count in; `None` for the high-level FAPs 1 (viseme) and
    /// 2 (expression).
    pub fapu: Option<Fapu>,
}

/// FAP 1..=68 in order: `FAPS[n - 1].number == n`.
pub const FAPS: [FapInfo; 68] = [
    FapInfo {
        number: 1,
        name: "viseme",
        fapu: None,
    },
    FapInfo {
        number: 2,
        name: "expression",
        fapu: None,
    },
    FapInfo {
        number: 3,
        name: "open_jaw",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 4,
        name: "lower_t_midlip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 5,
        name: "raise_b_midlip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 6,
        name: "stretch_l_cornerlip",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 7,
        name: "stretch_r_cornerlip",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 8,
        name: "lower_t_lip_lm",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 9,
        name: "lower_t_lip_rm",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 10,
        name: "raise_b_lip_lm",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 11,
        name: "raise_b_lip_rm",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 12,
        name: "raise_l_cornerlip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 13,
        name: "raise_r_cornerlip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 14,
        name: "thrust_jaw",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 15,
        name: "shift_jaw",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 16,
        name: "push_b_lip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 17,
        name: "push_t_lip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 18,
        name: "depress_chin",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 19,
        name: "close_t_l_eyelid",
        fapu: Some(Fapu::Irisd),
    },
    FapInfo {
        number: 20,
        name: "close_t_r_eyelid",
        fapu: Some(Fapu::Irisd),
    },
    FapInfo {
        number: 21,
        name: "close_b_l_eyelid",
        fapu: Some(Fapu::Irisd),
    },
    FapInfo {
        number: 22,
        name: "close_b_r_eyelid",
        fapu: Some(Fapu::Irisd),
    },
    FapInfo {
        number: 23,
        name: "yaw_l_eyeball",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 24,
        name: "yaw_r_eyeball",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 25,
        name: "pitch_l_eyeball",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 26,
        name: "pitch_r_eyeball",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 27,
        name: "thrust_l_eyeball",
        fapu: Some(Fapu::Es),
    },
    FapInfo {
        number: 28,
        name: "thrust_r_eyeball",
        fapu: Some(Fapu::Es),
    },
    FapInfo {
        number: 29,
        name: "dilate_l_pupil",
        fapu: Some(Fapu::Irisd),
    },
    FapInfo {
        number: 30,
        name: "dilate_r_pupil",
        fapu: Some(Fapu::Irisd),
    },
    FapInfo {
        number: 31,
        name: "raise_l_i_eyebrow",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 32,
        name: "raise_r_i_eyebrow",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 33,
        name: "raise_l_m_eyebrow",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 34,
        name: "raise_r_m_eyebrow",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 35,
        name: "raise_l_o_eyebrow",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 36,
        name: "raise_r_o_eyebrow",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 37,
        name: "squeeze_l_eyebrow",
        fapu: Some(Fapu::Es),
    },
    FapInfo {
        number: 38,
        name: "squeeze_r_eyebrow",
        fapu: Some(Fapu::Es),
    },
    FapInfo {
        number: 39,
        name: "puff_l_cheek",
        fapu: Some(Fapu::Es),
    },
    FapInfo {
        number: 40,
        name: "puff_r_cheek",
        fapu: Some(Fapu::Es),
    },
    FapInfo {
        number: 41,
        name: "lift_l_cheek",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 42,
        name: "lift_r_cheek",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 43,
        name: "shift_tongue_tip",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 44,
        name: "raise_tongue_tip",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 45,
        name: "thrust_tongue_tip",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 46,
        name: "raise_tongue",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 47,
        name: "tongue_roll",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 48,
        name: "head_pitch",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 49,
        name: "head_yaw",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 50,
        name: "head_roll",
        fapu: Some(Fapu::Au),
    },
    FapInfo {
        number: 51,
        name: "lower_t_midlip_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 52,
        name: "raise_b_midlip_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 53,
        name: "stretch_l_cornerlip_o",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 54,
        name: "stretch_r_cornerlip_o",
        fapu: Some(Fapu::Mw),
    },
    FapInfo {
        number: 55,
        name: "lower_t_lip_lm_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 56,
        name: "lower_t_lip_rm_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 57,
        name: "raise_b_lip_lm_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 58,
        name: "raise_b_lip_rm_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 59,
        name: "raise_l_cornerlip_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 60,
        name: "raise_r_cornerlip_o",
        fapu: Some(Fapu::Mns),
    },
    FapInfo {
        number: 61,
        name: "stretch_l_nose",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 62,
        name: "stretch_r_nose",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 63,
        name: "raise_nose",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 64,
        name: "bend_nose",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 65,
        name: "raise_l_ear",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 66,
        name: "raise_r_ear",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 67,
        name: "pull_l_ear",
        fapu: Some(Fapu::Ens),
    },
    FapInfo {
        number: 68,
        name: "pull_r_ear",
        fapu: Some(Fapu::Ens),
    },
];

/// Looks up a FAP by number (1..=68).
pub fn fap_info(number: u8) -> Option<&'static FapInfo> {
    FAPS.get(usize::from(number).checked_sub(1)?)
}

/// Looks up a FAP by its standard name (`open_jaw`), case-insensitively.
pub fn fap_by_name(name: &str) -> Option<&'static FapInfo> {
    FAPS.iter().find(|f| f.name.eq_ignore_ascii_case(name))
}

/// FAPU0 lengths of one neutral face, in mask units (CANDIDE report table 2).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct FapuValues {
    pub mns: f32,
    pub mw: f32,
    pub ens: f32,
    pub es: f32,
    pub irisd: f32,
}

/// Left pupil: mean of these CANDIDE vertices (+x is the face's left).
pub const LEFT_PUPIL: [usize; 4] = [67, 68, 71, 72];
/// Right pupil: mean of these CANDIDE vertices.
pub const RIGHT_PUPIL: [usize; 4] = [69, 70, 73, 74];

/// Mean position of a set of vertices.
pub fn centroid(vertices: &[Vec3], indices: &[usize]) -> Vec3 {
    indices.iter().map(|&i| vertices[i]).sum::<Vec3>() / indices.len() as f32
}

impl FapuValues {
    /// Measures the FAPU0 lengths on a CANDIDE-3 mask in its neutral pose (before the
    /// global rotation, scale and translation): MNS = 6.y - 87.y, MW = 31.x - 64.x,
    /// ENS = pupil.y - 6.y, ES = |rpupil.x - lpupil.x|, IRISD = 73.y - 74.y.
    pub fn measure(vertices: &[Vec3]) -> FapuValues {
        let left = centroid(vertices, &LEFT_PUPIL);
        let right = centroid(vertices, &RIGHT_PUPIL);
        let pupil_y = 0.5 * (left.y + right.y);
        FapuValues {
            mns: vertices[6].y - vertices[87].y,
            mw: vertices[31].x - vertices[64].x,
            ens: pupil_y - vertices[6].y,
            es: (right.x - left.x).abs(),
            irisd: vertices[73].y - vertices[74].y,
        }
    }

    /// Length of FAPU0 in mask units. For the angle unit this is the eyeball radius used
    /// to turn an eyeball rotation into the iris translation CANDIDE-3 implements
    /// (FAPs 23-26): one iris diameter, about 12 mm on an adult.
    pub fn length(&self, fapu: Fapu) -> f32 {
        match fapu {
            Fapu::Mns => self.mns,
            Fapu::Mw => self.mw,
            Fapu::Ens => self.ens,
            Fapu::Es => self.es,
            Fapu::Irisd => self.irisd,
            Fapu::Au => self.irisd,
        }
    }

    /// The animation-unit weight (mask units along the unit's stored direction) of a FAP
    /// value: `f * FAPU0 / 1024` for lengths, `f * 1e-5 * r_eye` for angles.
    pub fn weight(&self, fapu: Fapu, value: f32) -> f32 {
        match fapu {
            Fapu::Au => value * 1e-5 * self.length(fapu),
            _ => value * self.length(fapu) / 1024.0,
        }
    }
}
