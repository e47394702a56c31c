//! The integration tests of `momo`, in one test binary (each module was its own
//! binary before 2026-11-28; one binary compiles and links the dependencies' code once).

mod bound_cli;
mod cameras;
mod cli;
mod common;
mod doc_links;
mod images;
mod kitti;
mod kitti_folder;
mod pipeline_props;
mod recovery;
mod reliability;
mod sweep;
mod traffic_start;
