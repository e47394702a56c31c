//! Image sequences: one folder per camera, PNG or JPEG files in name order, frame k = the k-th
//! file of every folder. Images are decoded one frame at a time (nothing is cached), converted
//! to 8-bit gray and optionally gamma corrected.

use crate::error::MatchError;
use image::GrayImage;
use std::path::{Path, PathBuf};

/// The file extensions read (case-insensitive).
pub const IMAGE_EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

/// The image files of a multi-camera sequence: `files[camera][frame]`.
#[derive(Clone, Debug)]
pub struct ImageSequence {
    folders: Vec<PathBuf>,
    files: Vec<Vec<PathBuf>>,
    /// Per camera, the size every image must have (checked from the file's header, before
    /// decoding), with what set it.
    expected: Vec<Option<(u32, u32)>>,
}

impl ImageSequence {
    /// Lists the PNG and JPEG files of each folder (one folder per camera), sorted by file name.
    /// Fails on a missing folder, a folder without images, or folders with different numbers of
    /// images.
    pub fn open<P: AsRef<Path>>(folders: &[P]) -> Result<Self, MatchError> {
        if folders.is_empty() {
            return Err(MatchError::Option("no image folder given".into()));
        }
        let mut files = Vec::with_capacity(folders.len());
        for folder in folders {
            files.push(list_images(folder.as_ref())?);
        }
        let folders: Vec<PathBuf> = folders.iter().map(|f| f.as_ref().to_path_buf()).collect();
        for (j, list) in files.iter().enumerate().skip(1) {
            if list.len() != files[0].len() {
                return Err(MatchError::CountMismatch {
                    first: folders[0].clone(),
                    first_count: files[0].len(),
                    path: folders[j].clone(),
                    count: list.len(),
                });
            }
        }
        Ok(Self {
            folders,
            files,
            expected: Vec::new(),
        })
    }

    /// Every image of camera `j` must be `sizes[j]` (width, height, e.g. the rig's): checked
    /// from the file's header before the image is decoded, so that a small file declaring a
    /// huge image is refused without allocating it.
    pub fn expect_sizes(&mut self, sizes: Vec<Option<(u32, u32)>>) {
        self.expected = sizes;
    }

    /// Number of frames (images per camera).
    pub fn len(&self) -> usize {
        self.files.first().map_or(0, Vec::len)
    }

    /// True if there is no frame (never: [`open`](Self::open) rejects empty folders).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of cameras (folders).
    pub fn cameras(&self) -> usize {
        self.files.len()
    }

    /// The camera folders, in camera order.
    pub fn folders(&self) -> &[PathBuf] {
        &self.folders
    }

    /// The image file of `camera` at `frame`.
    pub fn path(&self, camera: usize, frame: usize) -> Option<&Path> {
        self.files.get(camera)?.get(frame).map(PathBuf::as_path)
    }

    /// Decodes frame `frame` of every camera (gray, gamma corrected with `gamma` if given).
    /// Fails naming the file if an image cannot be decoded or `frame` is out of range.
    pub fn load(
        &self,
        frame: usize,
        gamma: Option<&GammaTable>,
    ) -> Result<Vec<GrayImage>, MatchError> {
        (0..self.cameras())
            .map(|j| {
                let path = self.path(j, frame).ok_or_else(|| {
                    MatchError::Option(format!(
                        "frame {frame} is beyond the {} images of {}",
                        self.len(),
                        self.folders[j].display()
                    ))
                })?;
                if let Some(Some((ew, eh))) = self.expected.get(j) {
                    let (w, h) = image_size(path)?;
                    if (w, h) != (*ew, *eh) {
                        return Err(MatchError::ImageSize {
                            path: path.to_path_buf(),
                            width: w,
                            height: h,
                            expected: format!("the rig's camera {j}"),
                            expected_width: *ew,
                            expected_height: *eh,
                        });
                    }
                }
                let mut img = load_gray(path)?;
                if let Some(g) = gamma {
                    g.apply(&mut img);
                }
                Ok(img)
            })
            .collect()
    }
}

/// The PNG and JPEG files of a folder, sorted by name.
fn list_images(folder: &Path) -> Result<Vec<PathBuf>, MatchError> {
    if !folder.is_dir() {
        return Err(MatchError::NotAFolder {
            path: folder.to_path_buf(),
        });
    }
    let read_err = |source| MatchError::ReadDir {
        path: folder.to_path_buf(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(folder).map_err(read_err)? {
        let path = entry.map_err(read_err)?.path();
        let is_image = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| IMAGE_EXTENSIONS.iter().any(|x| x.eq_ignore_ascii_case(e)));
        if is_image && path.is_file() {
            files.push(path);
        }
    }
    if files.is_empty() {
        return Err(MatchError::NoImages {
            path: folder.to_path_buf(),
        });
    }
    files.sort();
    Ok(files)
}

/// The size (width, height) an image file declares in its header, read without decoding the
/// pixels (PNG or JPEG, recognised by content).
pub fn image_size(path: &Path) -> Result<(u32, u32), MatchError> {
    let file = std::fs::File::open(path).map_err(|e| MatchError::Decode {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    header_size(std::io::BufReader::new(file)).map_err(|reason| MatchError::Decode {
        path: path.to_path_buf(),
        reason,
    })
}

/// [`image_size`] of an encoded image in memory; `name` names it in errors.
pub fn image_size_from_bytes(bytes: &[u8], name: &Path) -> Result<(u32, u32), MatchError> {
    header_size(std::io::Cursor::new(bytes)).map_err(|reason| MatchError::Decode {
        path: name.to_path_buf(),
        reason,
    })
}

fn header_size<R: std::io::BufRead + std::io::Seek>(reader: R) -> Result<(u32, u32), String> {
    image::io::Reader::new(reader)
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .into_dimensions()
        .map_err(|e| e.to_string())
}

/// Decodes one image file to 8-bit gray (colour images are converted with the usual luma
/// weights; 16-bit images are scaled to 8 bits).
pub fn load_gray(path: &Path) -> Result<GrayImage, MatchError> {
    let file = std::fs::File::open(path).map_err(|e| MatchError::Decode {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    decode(std::io::BufReader::new(file)).map_err(|reason| MatchError::Decode {
        path: path.to_path_buf(),
        reason,
    })
}

/// [`load_gray`] of an encoded image in memory; `name` names it in errors.
pub fn decode_gray(bytes: &[u8], name: &Path) -> Result<GrayImage, MatchError> {
    decode(std::io::Cursor::new(bytes)).map_err(|reason| MatchError::Decode {
        path: name.to_path_buf(),
        reason,
    })
}

fn decode<R: std::io::BufRead + std::io::Seek>(reader: R) -> Result<GrayImage, String> {
    let img = image::io::Reader::new(reader)
        .with_guessed_format()
        .map_err(|e| e.to_string())?
        .decode()
        .map_err(|e| e.to_string())?;
    Ok(match img {
        image::DynamicImage::ImageLuma8(g) => g,
        other => other.to_luma8(),
    })
}

/// Gamma correction by a lookup table: `out = 255 (in / 255)^(1/gamma)`; `gamma > 1` brightens
/// dark regions (the paper corrects gamma against illumination changes).
#[derive(Clone, Debug)]
pub struct GammaTable {
    table: [u8; 256],
}

impl GammaTable {
    /// The table of `gamma` (finite and positive, else an error).
    pub fn new(gamma: f64) -> Result<Self, MatchError> {
        if !(gamma.is_finite() && gamma > 0.0) {
            return Err(MatchError::Option(format!(
                "gamma must be a positive number, found {gamma}"
            )));
        }
        let mut table = [0u8; 256];
        for (i, t) in table.iter_mut().enumerate() {
            let v = 255.0 * (i as f64 / 255.0).powf(1.0 / gamma);
            *t = v.round().clamp(0.0, 255.0) as u8;
        }
        Ok(Self { table })
    }

    /// Corrects an image in place.
    pub fn apply(&self, img: &mut GrayImage) {
        for p in img.iter_mut() {
            *p = self.table[usize::from(*p)];
        }
    }
}
