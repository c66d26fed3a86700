; A short job for examples/printer-heated.toml: heat the hot end while
; travelling to the start, wait for it on the timeline (M109), then print a
; square; the heater off at the end.
G21 G90 M83
M104 S200
G0 X20 Y20 Z0.3 F6000
M109 S200
G1 X80 Y20 E2.0 F1800
G1 X80 Y80 E2.0
G1 X20 Y80 E2.0
G1 X20 Y20 E2.0
M104 S0
G0 X0 Y0 F6000
