#!/bin/bash
# Sourced by pin_arms_build.sh and pin_robots_build.sh: write_pinocchio_headers SRC GEN writes, into
# GEN/pinocchio/, the headers Pinocchio's CMake (jrl-cmakemodules) would generate, for its use
# header-only from the source tree SRC (config.hpp from SRC/package.xml's version, the parsers'
# config.hpp, deprecated.hpp, warning.hpp).
write_pinocchio_headers() {
  local src=$1 gen=$2 PV PMAJ PMIN PPAT
  mkdir -p "$gen/pinocchio/parsers"
PV=$(sed -n 's:.*<version>\(.*\)</version>.*:\1:p' "$src/package.xml")
IFS=. read -r PMAJ PMIN PPAT <<< "$PV"
cat > "$gen"/pinocchio/config.hpp <<EOH
// Written by bench/peers/pin_headers.sh in place of the CMake-generated header (Pinocchio $PV, header-only use).
#ifndef PINOCCHIO_CONFIG_HPP
#define PINOCCHIO_CONFIG_HPP
#define PINOCCHIO_VERSION "$PV"
#define PINOCCHIO_MAJOR_VERSION $PMAJ
#define PINOCCHIO_MINOR_VERSION $PMIN
#define PINOCCHIO_PATCH_VERSION $PPAT
#define PINOCCHIO_VERSION_AT_LEAST(major, minor, patch) \\
  (PINOCCHIO_MAJOR_VERSION > major || (PINOCCHIO_MAJOR_VERSION >= major && (PINOCCHIO_MINOR_VERSION > minor || \\
   (PINOCCHIO_MINOR_VERSION >= minor && PINOCCHIO_PATCH_VERSION >= patch))))
#define PINOCCHIO_VERSION_AT_MOST(major, minor, patch) \\
  (PINOCCHIO_MAJOR_VERSION < major || (PINOCCHIO_MAJOR_VERSION <= major && (PINOCCHIO_MINOR_VERSION < minor || \\
   (PINOCCHIO_MINOR_VERSION <= minor && PINOCCHIO_PATCH_VERSION <= patch))))
#define PINOCCHIO_DLLAPI
#define PINOCCHIO_LOCAL
#define PINOCCHIO_EXPLICIT_INSTANTIATION_DECLARATION_DLLAPI
#define PINOCCHIO_EXPLICIT_INSTANTIATION_DEFINITION_DLLAPI
#endif
EOH
cat > "$gen"/pinocchio/parsers/config.hpp <<'EOH'
// Written by bench/peers/pin_headers.sh in place of the CMake-generated header (the parsers' export macros).
#ifndef PINOCCHIO_PARSERS_CONFIG_HPP
#define PINOCCHIO_PARSERS_CONFIG_HPP
#define PINOCCHIO_PARSERS_DLLAPI
#define PINOCCHIO_PARSERS_LOCAL
#endif
EOH
cat > "$gen"/pinocchio/deprecated.hpp <<'EOH'
// Written by bench/peers/pin_headers.sh in place of the CMake-generated header.
#ifndef PINOCCHIO_DEPRECATED_HPP
#define PINOCCHIO_DEPRECATED_HPP
#define PINOCCHIO_DEPRECATED __attribute__((deprecated))
#define PINOCCHIO_DEPRECATED_MESSAGE(message) __attribute__((deprecated(message)))
#endif
EOH
cat > "$gen"/pinocchio/warning.hpp <<'EOH'
// Written by bench/peers/pin_headers.sh in place of the CMake-generated header.
#ifndef PINOCCHIO_WARNING_HPP
#define PINOCCHIO_WARNING_HPP
#define PINOCCHIO_WARNING(message)
#endif
EOH
}
