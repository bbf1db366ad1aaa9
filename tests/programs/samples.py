"""Programs written the way the vendors' tools and their users write them: several declaration styles, partial
aggregates, comments, CRLF line ends, either case; shared by the readers' and the rewrite's tests."""

from __future__ import annotations

KRL_SRC = (
    "&ACCESS RVP\r\n"
    "&REL 12\r\n"
    "&PARAM TEMPLATE = C:\\KRC\\Roboter\\Template\\vorgabe\r\n"
    "DEF Weld_Seam( )\r\n"
    ";FOLD INI;%{PE}\r\n"
    "  ;FOLD BASISTECH INI\r\n"
    "    BAS (#INITMOV,0 )\r\n"
    "  ;ENDFOLD (BASISTECH INI)\r\n"
    ";ENDFOLD (INI)\r\n"
    "\r\n"
    ";FOLD PTP HOME  Vel= 100 % DEFAULT;%{PE}%MKUKATPBASIS,%CMOVE,%VPTP,%P 1:PTP, 2:HOME\r\n"
    "$BWDSTART = FALSE\r\n"
    "PTP  XHOME\r\n"
    ";ENDFOLD\r\n"
    ";FOLD LIN P1 CONT Vel=2 m/s CPDAT1 Tool[1]:torch Base[2]:table;%{PE}\r\n"
    "FDAT_ACT=FP1\r\n"
    "BAS(#CP_PARAMS,2)\r\n"
    "LIN XP1 C_DIS\r\n"
    ";ENDFOLD\r\n"
    "lin xp2 ; lower case, as typed\r\n"
    "$TOOL = TOOL_DATA[1]\r\n"
    "$BASE=$NULLFRAME\r\n"
    "LIN {X 850.5, Y -120.25, Z 640, A 180, B 0, C 180} C_VEL\r\n"
    "PTP {A1 0, A2 -90, A3 90, A4 0, A5 45, A6 0}\r\n"
    "LIN {X 900, Y 0} ; partial: the rest is where the robot is\r\n"
    "CIRC XAUX, XEND, CA 90\r\n"
    "SLIN PATH[2] WITH $VEL = 0.5\r\n"
    "LIN_REL {X 10, Y 0, Z 0, A 0, B 0, C 0}\r\n"
    "END\r\n"
)

KRL_DAT = (
    "&ACCESS RVP\r\n"
    "&REL 12\r\n"
    "DEFDAT  Weld_Seam PUBLIC\r\n"
    ";FOLD EXTERNAL DECLARATIONS;%{PE}%V3.2.0,%MKUKATPBASIS,%CEXT,%VCOMMON,%P\r\n"
    ";ENDFOLD (EXTERNAL DECLARATIONS)\r\n"
    'DECL BASIS_SUGG_T LAST_BASIS={POINT1[] "P1                      ",CP_PARAMS[] "CPDAT1"}\r\n'
    "DECL E6POS XP1={X 1224.5,Y -31.2,Z 866.0,A -178.5,B 45.25,C 179.9,S 6,T 27,E1 0.0,E2 0.0,E3 0.0,E4 0.0,E5 0.0,"
    "E6 0.0}\r\n"
    'DECL FDAT FP1={TOOL_NO 1,BASE_NO 2,IPO_FRAME #BASE,POINT2[] " ",TQ_STATE FALSE}\r\n'
    "DECL LDAT LCPDAT1={VEL 2.0,ACC 100.0,APO_DIST 100.0,APO_FAC 50.0,ORI_TYP #VAR}\r\n"
    "E6POS XP2={x 1300, y 0, z 800, a 0, b 90, c 0, s 'B010', t 'B000010'}\r\n"
    "DECL GLOBAL CONST POS XAUX={X 1000,Y 100,Z 700,A 0,B 90,C 0,S 2,T 0},XEND={X 1100,Y 200,Z 700,A 0,B 90,C 0}\r\n"
    "DECL E6POS PATH[3]\r\n"
    "PATH[1]={E6POS: X 1.5E2,Y 2,Z 3,A 4,B 5,C 6}\r\n"
    "PATH[2]={X 10,Y 20,Z 30,A 40,B 50,C 60,S 2,T 2}\r\n"
    "DECL FRAME F_PROBE={X 0,Y 0,Z 100,A 0,B 0,C 0}\r\n"
    "DECL INT counter=0\r\n"
    "ENDDAT\r\n"
)

KRL_CONFIG = (
    "DEFDAT  $CONFIG\r\n"
    "DECL GLOBAL FRAME TOOL_DATA[16]\r\n"
    "TOOL_DATA[1]={X 12.5,Y 0.0,Z 310.0,A 0.0,B -30.0,C 0.0}\r\n"
    "BASE_DATA[2]={X 1500.0,Y -300.0,Z 0.0,A 90.0,B 0.0,C 0.0}\r\n"
    "DECL GLOBAL E6AXIS XHOME={A1 0.0,A2 -90.0,A3 90.0,A4 0.0,A5 0.0,A6 0.0,E1 0.0}\r\n"
    "ENDDAT\r\n"
)

RAPID_MOD = (
    "%%%\r\n"
    "  VERSION:1\r\n"
    "  LANGUAGE:ENGLISH\r\n"
    "%%%\r\n"
    "MODULE MainModule\r\n"
    "    ! tool and work object, as the FlexPendant saves them\r\n"
    "    PERS tooldata tGun:=[TRUE,[[0,0,215.5],[0.965926,0,0.258819,0]],[2.1,[0,0,90],[1,0,0,0],0,0,0]];\r\n"
    '    TASK PERS wobjdata wobjTable:=[FALSE,TRUE,"",[[1200,-400,250],[1,0,0,0]],'
    "[[10,20,0],[0.707107,0,0,0.707107]]];\r\n"
    "    LOCAL CONST robtarget pApproach:=[[250.1,-12.30,400.00],[0.00428,-0.70709,0.70711,0.00428],[-1,0,-1,0],"
    "[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\r\n"
    "    CONST robtarget pWeld{2}:=[\r\n"
    "        [[300,0,50],[0,0,1,0],[0,-1,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]], ! first\r\n"
    "        [[350,0,50],[0,0,1,0],[0,-1,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]]];\r\n"
    "    PERS robtarget pLast:=[[1,2,3],[1,0,0,0],[0,0,0,0],[9E+09,9E+09,9E+09,9E+09,9E+09,9E+09]];\r\n"
    "    CONST jointtarget jHome:=[[0,-20,20,0,30,0],[9E9,9E9,9E9,9E9,9E9,9E9]];\r\n"
    "    VAR robtarget pTemp;\r\n"
    "    CONST speeddata vSlow:=[50,30,5000,1000];\r\n"
    "\r\n"
    "    PROC main()\r\n"
    "        MoveAbsJ jHome\\NoEOffs,v1000,fine,tool0;\r\n"
    "        MoveJ pApproach,v1000,z50,tGun\\WObj:=wobjTable;\r\n"
    "        MoveL pWeld{1}, vSlow, fine, tGun \\WObj:=wobjTable;\r\n"
    "        moveL pWeld{2},vSlow,z1,tGun\\WObj:=wobjTable;\r\n"
    "        MoveL [[500,0,600],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],v100,fine,tool0;\r\n"
    "        MoveL Offs(pApproach,0,0,50),v100,z10,tGun\\WObj:=wobjTable;\r\n"
    "        pTemp := CRobT(\\Tool:=tGun);\r\n"
    "        MoveC [[600,50,600],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],\r\n"
    "              [[650,0,600],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, z10, tool0;\r\n"
    "    ENDPROC\r\n"
    "ENDMODULE\r\n"
)

URSCRIPT = (
    "def weld_program():\n"
    "  set_standard_analog_input_domain(0, 1)\n"
    "  set_tcp(p[0.0,0.0,0.2155,0.0,0.0,0.0])\n"
    "  set_payload(2.1)\n"
    "  # begin: URCap Installation Node\n"
    "  global Plane_1=p[0.5,-0.2,0.05,0.0,0.0,1.5707963]\n"
    "  global Waypoint_1_p=p[.4, -.1, .35, 0, 3.1416, 0]\n"
    "  global Waypoint_1_q=[-0.2, -1.6, 1.7, -1.7, -1.57, 0.0]\n"
    "  global Waypoint_2_p=p[0.45,-0.10,0.30,0.0,-3.1416,0.0]   # the other half-turn spelling\n"
    '  $ 1 "Robot Program"\n'
    "  movej(get_inverse_kin(Waypoint_1_p, qnear=Waypoint_1_q), a=1.39, v=1.04)\n"
    "  movel(Waypoint_1_p, a=1.2, v=0.25)\n"
    "  movel(Waypoint_2_p, a=1.2, v=0.25, r=0.002)\n"
    "  movel(pose_trans(Plane_1, p[0.1, 0.0, 0.0, 0.0, 3.14159, 0.0]), a=1.2, v=0.25)\n"
    "  movep(p[0.3, 0.0, 0.3, 0, 3.14159, 0], a=1.2, v=0.25, r=0.01)\n"
    "  movec(p[0.3,0.05,0.3,0,3.14159,0], p[0.35,0.1,0.3,0,3.14159,0], a=1.2, v=0.25, r=0, mode=0)\n"
    "  movel(pose_add(get_actual_tcp_pose(), p[0, 0, 0.01, 0, 0, 0]), a=1.2, v=0.25)\n"
    "  movej([0, -1.57, 1.57, -1.57, -1.57, 0], a=1.4, v=1.05)\n"
    "  x = 0.3\n"
    "  movel(p[x, 0.1, 0.3, 0, 3.14159, 0])\n"
    "end\n"
)

CSV = (
    "# poses exported from the offline programming tool; mm and degrees\r\n"
    "name;x;y;z;a;b;c;speed\r\n"
    "P1;850.5;-120.25;640;180;0;180;fast\r\n"
    '"P 2";"900.000";0;640.0;-179.999;0.5;180;slow\r\n'
    "\r\n"
    "P3;1.0E3;5;6;0;90;0;\r\n"
)
