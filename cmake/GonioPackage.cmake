# make package: a .deb of the make install tree (CPack DEB, docs/install.md).
# Its postinst creates the gonio user and group and goniod's folders with
# systemd's own tools, as debhelper's dh_installsysusers/dh_installtmpfiles
# would, and restarts a running goniod on upgrade; prerm stops it on removal.
# Files under /etc are conffiles, so an upgrade keeps a lab's edits.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME gonio)
set(CPACK_PACKAGE_VENDOR "gonio project")
set(CPACK_PACKAGE_CONTACT "gonio maintainers <gonio@localhost>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "gonioreflectometer control: planner, capture daemon, BRDF fits")
set(CPACK_PACKAGE_FILE_NAME "gonio_${PROJECT_VERSION}")
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
# Library dependencies from the binaries (dpkg-shlibdeps), plus systemd's
# tools for the postinst.
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "systemd | systemd-standalone-sysusers")

set(GONIO_DEB_DIR ${PROJECT_BINARY_DIR}/deb)
file(MAKE_DIRECTORY ${GONIO_DEB_DIR})
foreach(script postinst prerm postrm)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/${script}.in ${GONIO_DEB_DIR}/${script}
                 @ONLY FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ
                 GROUP_EXECUTE WORLD_READ WORLD_EXECUTE)
endforeach()
# Every regular file make install puts under /etc (the models link is a
# link, not a conffile).
file(GLOB_RECURSE GONIO_ETC_FILES RELATIVE ${PROJECT_SOURCE_DIR}/configs
     ${PROJECT_SOURCE_DIR}/configs/plans/*.yaml ${PROJECT_SOURCE_DIR}/configs/rigs/*.yaml
     ${PROJECT_SOURCE_DIR}/configs/scenes/*.yaml ${PROJECT_SOURCE_DIR}/configs/render/*.yaml)
set(conffiles "${GONIO_INSTALL_CONFIG_DIR}/goniod.yaml\n")
foreach(f ${GONIO_ETC_FILES})
  string(APPEND conffiles "${GONIO_INSTALL_CONFIG_DIR}/${f}\n")
endforeach()
file(WRITE ${GONIO_DEB_DIR}/conffiles "${conffiles}")
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
    "${GONIO_DEB_DIR}/postinst;${GONIO_DEB_DIR}/prerm;${GONIO_DEB_DIR}/postrm;${GONIO_DEB_DIR}/conffiles")
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
include(CPack)
