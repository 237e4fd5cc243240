# `parallax simulate` and `parallax calibrate` refuse options that would be ignored or make no
# sense, each with one line naming the option, and check a --truth against the nominal before
# the fit (issue 17). Run with -DPARALLAX=<parallax> -DOUT=<folder>.
file(REMOVE_RECURSE ${OUT})
function(expect_refused what needle)
  execute_process(COMMAND ${PARALLAX} ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  if(status EQUAL 0)
    message(FATAL_ERROR "${what}: accepted\n${out}${err}")
  endif()
  string(FIND "${out}${err}" "${needle}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "${what}: the message lacks \"${needle}\":\n${out}${err}")
  endif()
  set(last_output "${out}${err}" PARENT_SCOPE)
endfunction()

expect_refused("--span 0" "--span: must be > 0"
               simulate --display demo --out ${OUT}/span0 --synthetic --span 0)
expect_refused("--noise-px without --synthetic" "--noise-px: applies only with --synthetic"
               simulate --display demo --out ${OUT}/noise --noise-px 1)

# A 16-module session, a truth of 8 modules: refused before any fitting.
execute_process(COMMAND ${PARALLAX} simulate --display demo --seed 3 --out ${OUT}/session --synthetic
                RESULT_VARIABLE status OUTPUT_QUIET)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "parallax simulate failed")
endif()
execute_process(COMMAND ${PARALLAX} display --preset demo --modules 8 --out ${OUT}/eight.json
                RESULT_VARIABLE status OUTPUT_QUIET ERROR_QUIET)
file(READ ${OUT}/eight.json made)
string(FIND "${made}" "\"demo-8-modules\"" named)
if(NOT status EQUAL 0 OR named EQUAL -1)
  message(FATAL_ERROR "a display made with --modules 8 is not named as a variant")
endif()
expect_refused("--truth with the wrong module count" "the ground truth has 8 modules"
               calibrate --captures ${OUT}/session --nominal ${OUT}/session/nominal.json
               --truth ${OUT}/eight.json --out ${OUT}/calib.json)
string(FIND "${last_output}" "correspondences" fitted)
if(NOT fitted EQUAL -1)
  message(FATAL_ERROR "the truth was checked only after loading and fitting:\n${last_output}")
endif()
expect_refused("--max-error-px 0" "--max-error-px: must be > 0"
               calibrate --captures ${OUT}/session --nominal ${OUT}/session/nominal.json
               --max-error-px 0 --out ${OUT}/calib.json)

# folder:DIR offline (no --link): the camera's metadata is needed, the folder must exist, and a
# folder without the pictures names the first one missing (issue 19).
expect_refused("folder: without metadata" "--camera folder:DIR needs the camera's metadata"
               calibrate --camera folder:${OUT}/pictures --nominal ${OUT}/session/nominal.json
               --out ${OUT}/calib.json)
expect_refused("folder: that does not exist" "the pictures' folder does not exist"
               calibrate --camera folder:${OUT}/pictures --camera-metadata ${OUT}/session/camera.json
               --nominal ${OUT}/session/nominal.json --out ${OUT}/calib.json)
file(MAKE_DIRECTORY ${OUT}/pictures)
expect_refused("folder: without its pictures" "no picture of \"station 0, modules 0,3,6,9,12,15, column pattern 0\""
               calibrate --camera folder:${OUT}/pictures --camera-metadata ${OUT}/session/camera.json
               --nominal ${OUT}/session/nominal.json --out ${OUT}/calib.json)
expect_refused("folder: and --photometric" "--photometric: needs --link"
               calibrate --camera folder:${OUT}/pictures --camera-metadata ${OUT}/session/camera.json
               --nominal ${OUT}/session/nominal.json --out ${OUT}/calib.json --photometric)
if(EXISTS ${OUT}/calib.json)
  message(FATAL_ERROR "a refused calibration installed ${OUT}/calib.json")
endif()
