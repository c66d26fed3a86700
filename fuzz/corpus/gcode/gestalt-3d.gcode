( Gestalt 3-axis machine: a helical bore, a square pocket outline and a )
( diagonal in all three axes, each node driving one axis on one clock.  )
G21 G90
G0 Z5
G0 X75 Y75
M3 S800
G0 X95 Y75
G1 Z0 F300
G2 X95 Y75 Z-3 I-20 J0 F600   ; helix: one turn down 3 mm
G2 X95 Y75 Z-6 I-20 J0
G2 X95 Y75 I-20 J0            ; clean-up pass at depth
G1 Z5 F300
G0 X20 Y20
G1 Z-2 F300
G1 X130 F900
G1 Y130
G1 X20
G1 Y20
G1 X130 Y130 Z-4 F600        ; all three axes at once
G0 Z10
M5
G4 P500
G0 X0 Y0 Z0
