//! The integration tests of `momo`, one test binary (each module was its own binary before
//! 2026-11-28: one binary links once, which is most of CI's test build time).

mod common;
mod bound_cli;
mod cameras;
mod cli;
mod doc_links;
mod images;
mod kitti;
mod kitti_folder;
mod pipeline_props;
mod recovery;
mod reliability;
mod sweep;
