// The identity of the model this library was built from: 16 hex digits of a digest over the sources that compute
// results (hwmodel/, firmware/, rtl_sim/, host/ but its command line), the tables compiled in and the toolchain
// and flags (host/model_identity.cmake, run by the build). Two builds of one version from other sources or with
// another compiler have other identities; the same sources built twice have the same one. Sweep point keys
// include it (point_key.h), so that rows of different builds never collect into one table.
#pragma once

namespace rtu::host {

const char* model_identity();

}  // namespace rtu::host
