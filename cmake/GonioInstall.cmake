# make install: the layout of a Debian daemon (docs/install.md).
#   /usr/bin                     gonio, goniod, gonio-sim
#   /etc/gonio                   goniod.yaml (the in-process simulated rig, so that
#                                the service starts without hardware), plans/,
#                                rigs/, scenes/, render/: what a lab edits
#   /etc/gonio/models            -> /usr/share/gonio/models (the latent decoder:
#                                data the package owns, not a setting)
#   /usr/lib/systemd/system      goniod.service
#   /usr/lib/sysusers.d          gonio.conf: the gonio user and group
#   /usr/lib/tmpfiles.d          gonio.conf: /run/goniod, /var/lib/gonio
#   /usr/share/man               gonio(1), gonio-sim(1), goniod.yaml(5), goniod(8)
#   /usr/share/doc/gonio         docs/*.md, README.md, the goniod config examples
#   /usr/lib/python3/dist-packages/gonio
#                                the Python client, with libgonio_model.so beside
#                                its modules (docs/python.md)
# The /etc and /var paths follow GNUInstallDirs: /etc for prefix /usr, else
# PREFIX/etc; systemd's folders are always under the prefix's lib.
install(TARGETS gonio goniod gonio-sim RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})

install(FILES configs/goniod/sim.yaml DESTINATION ${GONIO_INSTALL_CONFIG_DIR}
        RENAME goniod.yaml)
foreach(sub plans rigs scenes render standards)
  install(DIRECTORY configs/${sub} DESTINATION ${GONIO_INSTALL_CONFIG_DIR}
          FILES_MATCHING PATTERN "*.yaml")
endforeach()
install(FILES configs/models/latent-decoder.gld configs/models/README.md
        DESTINATION ${GONIO_INSTALL_DATA_DIR}/models)
file(RELATIVE_PATH GONIO_MODELS_LINK "${GONIO_INSTALL_CONFIG_DIR}" "${GONIO_INSTALL_DATA_DIR}/models")
install(CODE "
  set(link \"\$ENV{DESTDIR}${GONIO_INSTALL_CONFIG_DIR}/models\")
  file(REMOVE \"\${link}\")
  file(CREATE_LINK \"${GONIO_MODELS_LINK}\" \"\${link}\" SYMBOLIC)
  message(STATUS \"Installing: \${link} -> ${GONIO_MODELS_LINK}\")")

install(FILES configs/goniod.service DESTINATION ${CMAKE_INSTALL_PREFIX}/lib/systemd/system)
install(FILES configs/sysusers.d/gonio.conf DESTINATION ${CMAKE_INSTALL_PREFIX}/lib/sysusers.d)
install(FILES configs/tmpfiles.d/gonio.conf DESTINATION ${CMAKE_INSTALL_PREFIX}/lib/tmpfiles.d)

install(FILES docs/man/gonio.1 docs/man/gonio-sim.1 DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
install(FILES docs/man/goniod.yaml.5 DESTINATION ${CMAKE_INSTALL_MANDIR}/man5)
install(FILES docs/man/goniod.8 DESTINATION ${CMAKE_INSTALL_MANDIR}/man8)

file(GLOB GONIO_DOCS CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/docs/*.md)
install(FILES ${GONIO_DOCS} README.md LICENSE DESTINATION ${CMAKE_INSTALL_DOCDIR})
# source-tree.yaml runs goniod from a checkout (state in build/): no example
# for an installed system.
install(DIRECTORY configs/goniod/ DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples/goniod
        PATTERN "source-tree.yaml" EXCLUDE)

# The Python client: Debian's python3 looks in PREFIX/lib/python3/dist-packages.
set(GONIO_INSTALL_PYTHON_DIR "${CMAKE_INSTALL_PREFIX}/lib/python3/dist-packages/gonio")
install(DIRECTORY python/gonio/ DESTINATION ${GONIO_INSTALL_PYTHON_DIR}
        FILES_MATCHING PATTERN "*.py" PATTERN "__pycache__" EXCLUDE)
install(TARGETS gonio_model LIBRARY DESTINATION ${GONIO_INSTALL_PYTHON_DIR})
