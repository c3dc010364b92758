# Install layout and Debian packages (CPack DEB).
#
#   sitepose      the commands, the detector plugins, the systemd unit, the
#                 default daemon config (/etc/sitepose/siteposed.yaml, a
#                 conffile), the LCM types, the DBC, firmware-config, docs;
#   sitepose-dev  the detector plugin ABI header and the LCM message types
#                 generated at build time for C++ (headers), C (headers and
#                 a static library), Python (the package `sitepose`) and Java
#                 (a jar), for integrators' own plugins and receivers
#                 (examples/lcm/ shows each).
#
# Depends: comes from dpkg-shlibdeps on the installed binaries. The maintainer
# scripts are packaging/deb/{postinst,prerm,postrm}. Build the packages with
# tools/package.sh (or `cpack -G DEB` in a build tree).

set(SITEPOSE_DOC_DIR share/doc/sitepose)
set(SITEPOSE_DATA_DIR share/sitepose)

install(TARGETS sitepose siteposed RUNTIME DESTINATION bin COMPONENT runtime)
install(FILES systemd/siteposed.service DESTINATION lib/systemd/system COMPONENT runtime)
install(FILES config/siteposed.yaml DESTINATION /etc/sitepose COMPONENT runtime)
install(FILES config/sitepose.yaml config/orbslam2/sitepose_default_stereo.yaml
  DESTINATION ${SITEPOSE_DATA_DIR}/config COMPONENT runtime)
install(DIRECTORY config/lcm/ DESTINATION ${SITEPOSE_DATA_DIR}/lcm COMPONENT runtime
  FILES_MATCHING PATTERN "*.lcm")
install(FILES config/can/sitepose.dbc DESTINATION ${SITEPOSE_DATA_DIR}/can COMPONENT runtime)
install(DIRECTORY firmware-config/ DESTINATION ${SITEPOSE_DATA_DIR}/firmware-config
  COMPONENT runtime)
# Run as `python3 /usr/share/sitepose/tools/can_decode.py` (Suggests: python3-can).
install(FILES tools/can_decode.py DESTINATION ${SITEPOSE_DATA_DIR}/tools COMPONENT runtime)
install(FILES README.md DESTINATION ${SITEPOSE_DOC_DIR} COMPONENT runtime)
install(FILES systemd/README.md DESTINATION ${SITEPOSE_DOC_DIR} RENAME systemd.md
  COMPONENT runtime)
install(DIRECTORY docs/ DESTINATION ${SITEPOSE_DOC_DIR}/docs COMPONENT runtime)

install(FILES include/sitepose/detect/plugin_abi.h DESTINATION include/sitepose/detect
  COMPONENT dev)
# lcm-gen's classes (#include "sitepose/pose_t.hpp"), generated in the build tree.
install(DIRECTORY ${PROJECT_BINARY_DIR}/src/output/lcm_gen/sitepose/
  DESTINATION include/sitepose COMPONENT dev FILES_MATCHING PATTERN "*.hpp")
# C: #include <sitepose/sitepose_pose_t.h>, -lsitepose_lcmtypes -llcm.
install(TARGETS sitepose_lcm_bindings_c ARCHIVE DESTINATION lib COMPONENT dev)
install(DIRECTORY ${PROJECT_BINARY_DIR}/src/output/lcm_bindings/c/include/sitepose/
  DESTINATION include/sitepose COMPONENT dev FILES_MATCHING PATTERN "*.h")
# Python: `from sitepose import pose_t` (standard library only).
install(DIRECTORY ${PROJECT_BINARY_DIR}/src/output/lcm_bindings/python/sitepose
  DESTINATION lib/python3/dist-packages COMPONENT dev FILES_MATCHING PATTERN "*.py"
  PATTERN __pycache__ EXCLUDE)
# Java: sitepose-lcmtypes-<version>.jar and the link sitepose-lcmtypes.jar
# beside liblcm-java's lcm.jar.
install_jar(sitepose_lcm_bindings_java DESTINATION share/java COMPONENT dev)
install(FILES examples/lcm/README.md examples/lcm/pose_subscriber.cpp examples/lcm/pose_subscriber.c
  examples/lcm/pose_subscriber.py examples/lcm/PoseSubscriber.java
  DESTINATION share/doc/sitepose-dev/examples COMPONENT dev)

# Debian's per-package copyright and changelog (compressed, as policy asks).
set(SITEPOSE_DEB_STAGE ${PROJECT_BINARY_DIR}/packaging)
string(TIMESTAMP SITEPOSE_DEB_DATE "%a, %d %b %Y %H:%M:%S +0000" UTC)
configure_file(packaging/deb/changelog.in ${SITEPOSE_DEB_STAGE}/changelog.Debian @ONLY)
execute_process(COMMAND gzip -9nf ${SITEPOSE_DEB_STAGE}/changelog.Debian
  RESULT_VARIABLE gzip_result)
if(NOT gzip_result EQUAL 0)
  message(FATAL_ERROR "gzip of the Debian changelog failed")
endif()
foreach(pair IN ITEMS "runtime:sitepose" "dev:sitepose-dev")
  string(REPLACE ":" ";" pair ${pair})
  list(GET pair 0 component)
  list(GET pair 1 package)
  install(FILES packaging/deb/copyright ${SITEPOSE_DEB_STAGE}/changelog.Debian.gz
    DESTINATION share/doc/${package} COMPONENT ${component})
endforeach()
configure_file(packaging/deb/conffiles ${SITEPOSE_DEB_STAGE}/runtime/conffiles COPYONLY)
foreach(script postinst prerm postrm)
  file(COPY packaging/deb/${script} DESTINATION ${SITEPOSE_DEB_STAGE}/runtime
    FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE
    WORLD_READ WORLD_EXECUTE)
endforeach()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME sitepose)
set(CPACK_PACKAGE_VENDOR "sitepose")
set(CPACK_PACKAGE_CONTACT "sitepose maintainers <sitepose@example.org>")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)  # Debian revision: 0.1.0-1
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_COMPRESSION_TYPE gzip)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME sitepose)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SUGGESTS "python3-can")
# siteposed reads the EGM96 geoid grid (geo.geoid); shlibdeps adds the libraries.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "proj-data")
# CPack indents the extended description itself.
set(CPACK_DEBIAN_RUNTIME_DESCRIPTION
  "stereo visual positioning service for construction machines
sitepose keeps a centimetre-class pose from a side-facing stereo camera
where RTK-GNSS drops out, even when other machines cover most of the view.
This package holds the sitepose command (simulate, run, evaluate), the
siteposed daemon with its systemd unit, the detector plugins, the LCM
message types and the CAN database (J1939 / NMEA 2000).")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA
  ${SITEPOSE_DEB_STAGE}/runtime/conffiles ${SITEPOSE_DEB_STAGE}/runtime/postinst
  ${SITEPOSE_DEB_STAGE}/runtime/prerm ${SITEPOSE_DEB_STAGE}/runtime/postrm)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_STRICT_PERMISSION ON)
set(CPACK_DEBIAN_DEV_PACKAGE_NAME sitepose-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS "liblcm-dev")
# Java receivers need LCM's own classes; Python ones only python3.
set(CPACK_DEBIAN_DEV_PACKAGE_SUGGESTS "liblcm-java, python3")
set(CPACK_DEBIAN_DEV_DESCRIPTION
  "stereo visual positioning service - plugin ABI and LCM message types
Files for building against sitepose: the C ABI of detector plugins
(sitepose/detect/plugin_abi.h) and the LCM messages siteposed publishes
(pose_t, health_t, gnss_fix_t) for C++ (sitepose/pose_t.hpp), C
(sitepose/sitepose_pose_t.h, libsitepose_lcmtypes.a), Python (the package
sitepose, no lcm module needed) and Java (sitepose-lcmtypes.jar), with a
subscriber example in each language.")
include(CPack)
