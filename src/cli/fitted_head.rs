//! The arguments of every command that works on a head with its fitted mask (`deform`,
//! `compare`, `arkit-basis`), parsed and loaded in one place.

use super::{load_fit, load_head, load_mask, FilePath};
use crate::deform::{Registration, RegistrationError};
use crate::fit::FittedMask;
use crate::head::Head;

#[derive(Debug, clap::Args)]
pub struct FittedHeadArgs {
    /// The head mesh (OBJ).
    #[arg(long)]
    pub head: FilePath,
    /// The fit of the CANDIDE-3 mask to that head (.fit.toml).
    #[arg(long)]
    pub fit: FilePath,
    /// A CANDIDE-3 .wfm instead of the embedded one.
    #[arg(long)]
    pub mask: Option<FilePath>,
}

impl FittedHeadArgs {
    /// Loads the mask, the fit and the head, each error naming its file.
    pub fn load(&self) -> Result<(Head, FittedMask), Box<dyn std::error::Error + Send + Sync>> {
        let mask = load_mask(self.mask.as_deref())?;
        let fit = load_fit(&self.fit, &mask)?;
        let head = load_head(&self.head)?;
        Ok((head, FittedMask::new(mask, fit)))
    }

    /// Registers the loaded head ([`Registration::try_new`]), saying on stderr when its
    /// mouth, open at rest, was closed for animation.
    pub fn register(&self, head: Head, fitted: FittedMask) -> Result<Registration, RegistrationError> {
        let registration = Registration::try_new(head, fitted)?;
        if let Some(closed) = registration.mouth_calibration {
            eprintln!(
                "{}: the inner lips are {:.1} mm apart at rest; closed for animation (the lower lip raised {:.1} mm)",
                self.head.display(),
                closed.open_mm,
                closed.raised_mm
            );
        }
        Ok(registration)
    }

    /// The arguments as typed: `--head H --fit F [--mask M]`, for commands written into
    /// reports.
    pub fn words(&self) -> Vec<(&'static str, String)> {
        let mut words = vec![
            ("--head", self.head.display().to_string()),
            ("--fit", self.fit.display().to_string()),
        ];
        if let Some(mask) = &self.mask {
            words.push(("--mask", mask.display().to_string()));
        }
        words
    }
}
