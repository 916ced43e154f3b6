from wmr_mission.cli import main

main()
