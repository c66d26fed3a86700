; A badge for the laser cutter: a cut-out circle with an engraved star and
; a frame. Laser power follows S (0..1000) and switches on the fly.
G21 G90
G0 X150 Y100
M3 S300                      ; engrave at 30 %
G1 X250 Y100 F3000           ; frame
G1 X250 Y200
G1 X150 Y200
G1 X150 Y100
M5
G0 X200 Y185                 ; a five-pointed star
M3 S450
G1 X208.82 Y162.14 F2400
G1 X233.3 Y160.9
G1 X214.27 Y145.36
G1 X220.57 Y121.64
G1 X200 Y135
G1 X179.43 Y121.64
G1 X185.73 Y145.36
G1 X166.7 Y160.9
G1 X191.18 Y162.14
G1 X200 Y185
M5
G0 X240 Y150                 ; cut the badge out: a full circle, IJ form
M3 S1000
G2 X240 Y150 I-40 J0 F900
M5
G0 X120 Y60                  ; an arc in R form and a pause
M3 S600
G3 X160 Y60 R25 F1500
G4 P250
G1 X180 Y40
M5
G0 X0 Y0
