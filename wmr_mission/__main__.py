from wmr_mission.cli import program

program()
