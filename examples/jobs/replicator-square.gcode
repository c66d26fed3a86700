; A first layer for the Replicator 2-like printer over S3G: heat the
; platform and the extruder (waiting for both), prime, a square outline
; and an arc with the cooling fan on, then a short pause at rest.
G21
G90
M82
M140 S60          ; platform
M104 S210         ; extruder, no wait
M190 S60          ; wait for the platform
M109 S210         ; wait for the extruder
G92 E0
G1 Z0.3 F600
G1 X20 Y20 F6000
G1 X60 Y20 E2.0 F1800
M106 S255         ; cooling fan on
G1 X60 Y60 E4.0
G1 X20 Y60 E6.0
G1 X20 Y20 E8.0
G2 X40 Y40 I10 J10 E9.5 F1200
G4 P250           ; dwell a quarter second
M107
G1 Z5 F600
G1 X100 Y100 F9000
M104 S0
M140 S0
