;; The 7 x 7 blockworld: ten single-cell regions at the cells below (x, y), as in the
;; reproduction of the paper's setting (RAraghavarora/anticipatory_rl, paper1_blockworld):
;; red (1,1) blue (3,1) green (5,1) cyan (1,3) pink (3,3) orange (5,3) brown (1,5),
;; white1 (3,5) white2 (5,5) white3 (5,6). A move costs 25 per grid step of the
;; Manhattan path between the two cells (unit-cost 4-connected travel, blocks not
;; treated as obstacles). Blocks a-e are coloured, f-h white. The :init placement and
;; robot position are the first choices of domain.toml's [[reset]] entries.
(define (problem blockworld-grid7x7)
  (:domain blockworld)
  (:objects
    red blue green cyan pink orange brown - colored-region
    white1 white2 white3 - white-region
    a b c d e - colored-block
    f g h - white-block
    a_cyan a_pink c_cyan c_red d_orange e_pink e_red - single-job
    a_blue_e_orange a_blue_e_pink a_brown_e_pink a_green_e_cyan a_pink_c_red a_red_b_pink b_blue_c_brown b_blue_c_cyan b_orange_d_red b_pink_e_red c_pink_d_cyan c_pink_e_cyan d_orange_e_green - pair-job)
  (:init
    (robot-at pink) (hand-free)
    (at a white1) (at b white3) (at c white2) (at d green) (at e red) (at f brown) (at g blue) (at h cyan)
    ;; the task library: what each job wants
    (wants a_cyan a cyan)
    (wants a_pink a pink)
    (wants c_cyan c cyan)
    (wants c_red c red)
    (wants d_orange d orange)
    (wants e_pink e pink)
    (wants e_red e red)
    (wants a_blue_e_orange a blue) (wants a_blue_e_orange e orange)
    (wants a_blue_e_pink a blue) (wants a_blue_e_pink e pink)
    (wants a_brown_e_pink a brown) (wants a_brown_e_pink e pink)
    (wants a_green_e_cyan a green) (wants a_green_e_cyan e cyan)
    (wants a_pink_c_red a pink) (wants a_pink_c_red c red)
    (wants a_red_b_pink a red) (wants a_red_b_pink b pink)
    (wants b_blue_c_brown b blue) (wants b_blue_c_brown c brown)
    (wants b_blue_c_cyan b blue) (wants b_blue_c_cyan c cyan)
    (wants b_orange_d_red b orange) (wants b_orange_d_red d red)
    (wants b_pink_e_red b pink) (wants b_pink_e_red e red)
    (wants c_pink_d_cyan c pink) (wants c_pink_d_cyan d cyan)
    (wants c_pink_e_cyan c pink) (wants c_pink_e_cyan e cyan)
    (wants d_orange_e_green d orange) (wants d_orange_e_green e green)
    (= (total-cost) 0)
    (= (move-cost red blue) 50) (= (move-cost red green) 100) (= (move-cost red cyan) 50) (= (move-cost red pink) 100) (= (move-cost red orange) 150) (= (move-cost red brown) 100) (= (move-cost red white1) 150) (= (move-cost red white2) 200) (= (move-cost red white3) 225)
    (= (move-cost blue red) 50) (= (move-cost blue green) 50) (= (move-cost blue cyan) 100) (= (move-cost blue pink) 50) (= (move-cost blue orange) 100) (= (move-cost blue brown) 150) (= (move-cost blue white1) 100) (= (move-cost blue white2) 150) (= (move-cost blue white3) 175)
    (= (move-cost green red) 100) (= (move-cost green blue) 50) (= (move-cost green cyan) 150) (= (move-cost green pink) 100) (= (move-cost green orange) 50) (= (move-cost green brown) 200) (= (move-cost green white1) 150) (= (move-cost green white2) 100) (= (move-cost green white3) 125)
    (= (move-cost cyan red) 50) (= (move-cost cyan blue) 100) (= (move-cost cyan green) 150) (= (move-cost cyan pink) 50) (= (move-cost cyan orange) 100) (= (move-cost cyan brown) 50) (= (move-cost cyan white1) 100) (= (move-cost cyan white2) 150) (= (move-cost cyan white3) 175)
    (= (move-cost pink red) 100) (= (move-cost pink blue) 50) (= (move-cost pink green) 100) (= (move-cost pink cyan) 50) (= (move-cost pink orange) 50) (= (move-cost pink brown) 100) (= (move-cost pink white1) 50) (= (move-cost pink white2) 100) (= (move-cost pink white3) 125)
    (= (move-cost orange red) 150) (= (move-cost orange blue) 100) (= (move-cost orange green) 50) (= (move-cost orange cyan) 100) (= (move-cost orange pink) 50) (= (move-cost orange brown) 150) (= (move-cost orange white1) 100) (= (move-cost orange white2) 50) (= (move-cost orange white3) 75)
    (= (move-cost brown red) 100) (= (move-cost brown blue) 150) (= (move-cost brown green) 200) (= (move-cost brown cyan) 50) (= (move-cost brown pink) 100) (= (move-cost brown orange) 150) (= (move-cost brown white1) 50) (= (move-cost brown white2) 100) (= (move-cost brown white3) 125)
    (= (move-cost white1 red) 150) (= (move-cost white1 blue) 100) (= (move-cost white1 green) 150) (= (move-cost white1 cyan) 100) (= (move-cost white1 pink) 50) (= (move-cost white1 orange) 100) (= (move-cost white1 brown) 50) (= (move-cost white1 white2) 50) (= (move-cost white1 white3) 75)
    (= (move-cost white2 red) 200) (= (move-cost white2 blue) 150) (= (move-cost white2 green) 100) (= (move-cost white2 cyan) 150) (= (move-cost white2 pink) 100) (= (move-cost white2 orange) 50) (= (move-cost white2 brown) 100) (= (move-cost white2 white1) 50) (= (move-cost white2 white3) 25)
    (= (move-cost white3 red) 225) (= (move-cost white3 blue) 175) (= (move-cost white3 green) 125) (= (move-cost white3 cyan) 175) (= (move-cost white3 pink) 125) (= (move-cost white3 orange) 75) (= (move-cost white3 brown) 125) (= (move-cost white3 white1) 75) (= (move-cost white3 white2) 25))
  ;; A layout's own goal: the library's last task, d_orange_e_green.
  (:goal (and (at d orange) (at e green) (hand-free)))
  (:metric minimize (total-cost)))
