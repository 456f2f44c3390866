//! Build script. With the `usd` feature, bakes the run-time search path of the libpython that
//! pyo3 was configured against into the binary: without it the loader may pick another
//! libpython of the same version (a distribution's), whose `sys.prefix` and site-packages
//! differ from the interpreter the venv was made with.

fn main() {
    #[cfg(feature = "usd")]
    pyo3_build_config::add_libpython_rpath_link_args();
}
