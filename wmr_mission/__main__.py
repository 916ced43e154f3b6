from wmr_mission._start import program

program()
