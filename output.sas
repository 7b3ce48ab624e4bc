begin_version
3
end_version
begin_metric
1
end_metric
64
begin_variable
var0
-1
7
Atom robot-at(coffeemachine)
Atom robot-at(countertop)
Atom robot-at(dishwasher)
Atom robot-at(fountain)
Atom robot-at(pantry)
Atom robot-at(servingtable)
Atom robot-at(shelf)
end_variable
begin_variable
var1
-1
2
Atom at(apple_0, coffeemachine)
NegatedAtom at(apple_0, coffeemachine)
end_variable
begin_variable
var2
-1
2
Atom at(apple_0, dishwasher)
NegatedAtom at(apple_0, dishwasher)
end_variable
begin_variable
var3
-1
2
Atom at(apple_0, fountain)
NegatedAtom at(apple_0, fountain)
end_variable
begin_variable
var4
-1
2
Atom at(apple_0, pantry)
NegatedAtom at(apple_0, pantry)
end_variable
begin_variable
var5
-1
2
Atom at(apple_0, servingtable)
NegatedAtom at(apple_0, servingtable)
end_variable
begin_variable
var6
-1
2
Atom at(apple_0, shelf)
NegatedAtom at(apple_0, shelf)
end_variable
begin_variable
var7
-1
2
Atom at(bowl_0, coffeemachine)
NegatedAtom at(bowl_0, coffeemachine)
end_variable
begin_variable
var8
-1
2
Atom at(bowl_0, countertop)
NegatedAtom at(bowl_0, countertop)
end_variable
begin_variable
var9
-1
2
Atom at(bowl_0, dishwasher)
NegatedAtom at(bowl_0, dishwasher)
end_variable
begin_variable
var10
-1
2
Atom at(bowl_0, fountain)
NegatedAtom at(bowl_0, fountain)
end_variable
begin_variable
var11
-1
2
Atom at(bowl_0, pantry)
NegatedAtom at(bowl_0, pantry)
end_variable
begin_variable
var12
-1
2
Atom at(bowl_0, servingtable)
NegatedAtom at(bowl_0, servingtable)
end_variable
begin_variable
var13
-1
2
Atom at(bowl_0, shelf)
NegatedAtom at(bowl_0, shelf)
end_variable
begin_variable
var14
-1
2
Atom at(cup_0, coffeemachine)
NegatedAtom at(cup_0, coffeemachine)
end_variable
begin_variable
var15
-1
2
Atom at(cup_0, countertop)
NegatedAtom at(cup_0, countertop)
end_variable
begin_variable
var16
-1
2
Atom at(cup_0, dishwasher)
NegatedAtom at(cup_0, dishwasher)
end_variable
begin_variable
var17
-1
2
Atom at(cup_0, fountain)
NegatedAtom at(cup_0, fountain)
end_variable
begin_variable
var18
-1
2
Atom at(cup_0, pantry)
NegatedAtom at(cup_0, pantry)
end_variable
begin_variable
var19
-1
2
Atom at(cup_0, servingtable)
NegatedAtom at(cup_0, servingtable)
end_variable
begin_variable
var20
-1
2
Atom at(cup_0, shelf)
NegatedAtom at(cup_0, shelf)
end_variable
begin_variable
var21
-1
2
Atom at(cup_1, coffeemachine)
NegatedAtom at(cup_1, coffeemachine)
end_variable
begin_variable
var22
-1
2
Atom at(cup_1, countertop)
NegatedAtom at(cup_1, countertop)
end_variable
begin_variable
var23
-1
2
Atom at(cup_1, dishwasher)
NegatedAtom at(cup_1, dishwasher)
end_variable
begin_variable
var24
-1
2
Atom at(cup_1, fountain)
NegatedAtom at(cup_1, fountain)
end_variable
begin_variable
var25
-1
2
Atom at(cup_1, pantry)
NegatedAtom at(cup_1, pantry)
end_variable
begin_variable
var26
-1
2
Atom at(cup_1, servingtable)
NegatedAtom at(cup_1, servingtable)
end_variable
begin_variable
var27
-1
2
Atom at(cup_1, shelf)
NegatedAtom at(cup_1, shelf)
end_variable
begin_variable
var28
-1
2
Atom at(jar_0, coffeemachine)
NegatedAtom at(jar_0, coffeemachine)
end_variable
begin_variable
var29
-1
2
Atom at(jar_0, countertop)
NegatedAtom at(jar_0, countertop)
end_variable
begin_variable
var30
-1
2
Atom at(jar_0, dishwasher)
NegatedAtom at(jar_0, dishwasher)
end_variable
begin_variable
var31
-1
2
Atom at(jar_0, fountain)
NegatedAtom at(jar_0, fountain)
end_variable
begin_variable
var32
-1
2
Atom at(jar_0, pantry)
NegatedAtom at(jar_0, pantry)
end_variable
begin_variable
var33
-1
2
Atom at(jar_0, servingtable)
NegatedAtom at(jar_0, servingtable)
end_variable
begin_variable
var34
-1
2
Atom at(jar_0, shelf)
NegatedAtom at(jar_0, shelf)
end_variable
begin_variable
var35
-1
2
Atom at(knife_0, coffeemachine)
NegatedAtom at(knife_0, coffeemachine)
end_variable
begin_variable
var36
-1
2
Atom at(knife_0, countertop)
NegatedAtom at(knife_0, countertop)
end_variable
begin_variable
var37
-1
2
Atom at(knife_0, dishwasher)
NegatedAtom at(knife_0, dishwasher)
end_variable
begin_variable
var38
-1
2
Atom at(knife_0, fountain)
NegatedAtom at(knife_0, fountain)
end_variable
begin_variable
var39
-1
2
Atom at(knife_0, pantry)
NegatedAtom at(knife_0, pantry)
end_variable
begin_variable
var40
-1
2
Atom at(knife_0, servingtable)
NegatedAtom at(knife_0, servingtable)
end_variable
begin_variable
var41
-1
2
Atom at(knife_0, shelf)
NegatedAtom at(knife_0, shelf)
end_variable
begin_variable
var42
-1
2
Atom at(plate_0, coffeemachine)
NegatedAtom at(plate_0, coffeemachine)
end_variable
begin_variable
var43
-1
2
Atom at(plate_0, countertop)
NegatedAtom at(plate_0, countertop)
end_variable
begin_variable
var44
-1
2
Atom at(plate_0, dishwasher)
NegatedAtom at(plate_0, dishwasher)
end_variable
begin_variable
var45
-1
2
Atom at(plate_0, fountain)
NegatedAtom at(plate_0, fountain)
end_variable
begin_variable
var46
-1
2
Atom at(plate_0, pantry)
NegatedAtom at(plate_0, pantry)
end_variable
begin_variable
var47
-1
2
Atom at(plate_0, servingtable)
NegatedAtom at(plate_0, servingtable)
end_variable
begin_variable
var48
-1
2
Atom at(plate_0, shelf)
NegatedAtom at(plate_0, shelf)
end_variable
begin_variable
var49
-1
8
Atom hand-free()
Atom holding(apple_0)
Atom holding(bowl_0)
Atom holding(cup_0)
Atom holding(cup_1)
Atom holding(jar_0)
Atom holding(knife_0)
Atom holding(plate_0)
end_variable
begin_variable
var50
-1
2
Atom has-water(jar_0)
NegatedAtom has-water(jar_0)
end_variable
begin_variable
var51
-1
2
Atom dirty(cup_0)
NegatedAtom dirty(cup_0)
end_variable
begin_variable
var52
-1
2
Atom dirty(cup_1)
NegatedAtom dirty(cup_1)
end_variable
begin_variable
var53
-1
2
Atom has-coffee(cup_0)
NegatedAtom has-coffee(cup_0)
end_variable
begin_variable
var54
-1
2
Atom has-water(cup_0)
NegatedAtom has-water(cup_0)
end_variable
begin_variable
var55
-1
2
Atom has-coffee(cup_1)
NegatedAtom has-coffee(cup_1)
end_variable
begin_variable
var56
-1
2
Atom has-water(cup_1)
NegatedAtom has-water(cup_1)
end_variable
begin_variable
var57
-1
2
Atom at(apple_0, countertop)
NegatedAtom at(apple_0, countertop)
end_variable
begin_variable
var58
-1
2
Atom dirty(knife_0)
NegatedAtom dirty(knife_0)
end_variable
begin_variable
var59
-1
2
Atom has-coffee(bowl_0)
NegatedAtom has-coffee(bowl_0)
end_variable
begin_variable
var60
-1
2
Atom dirty(bowl_0)
NegatedAtom dirty(bowl_0)
end_variable
begin_variable
var61
-1
2
Atom has-water(bowl_0)
NegatedAtom has-water(bowl_0)
end_variable
begin_variable
var62
-1
2
Atom at(water_machine, coffeemachine)
NegatedAtom at(water_machine, coffeemachine)
end_variable
begin_variable
var63
0
2
Atom new-axiom@0()
NegatedAtom new-axiom@0()
end_variable
0
begin_state
5
1
1
1
1
1
1
1
0
1
1
1
1
1
1
1
1
1
1
0
1
1
1
1
0
1
1
1
1
0
1
1
1
1
1
1
0
1
1
1
1
1
1
1
1
0
1
1
1
0
1
0
0
1
1
1
1
0
1
1
1
1
1
1
end_state
begin_goal
1
63 0
end_goal
184
begin_operator
drain bowl_0 water_fountain fountain
2
49 2
0 3
1
0 61 0 1
50
end_operator
begin_operator
drain cup_0 water_fountain fountain
2
49 3
0 3
1
0 54 0 1
50
end_operator
begin_operator
drain cup_1 water_fountain fountain
2
49 4
0 3
1
0 56 0 1
50
end_operator
begin_operator
drain jar_0 water_fountain fountain
2
49 5
0 3
1
0 50 0 1
50
end_operator
begin_operator
fill bowl_0 water_fountain fountain
4
60 1
49 2
59 1
0 3
1
0 61 1 0
1000
end_operator
begin_operator
fill cup_0 water_fountain fountain
4
51 1
49 3
53 1
0 3
1
0 54 1 0
1000
end_operator
begin_operator
fill cup_1 water_fountain fountain
4
52 1
49 4
55 1
0 3
1
0 56 1 0
1000
end_operator
begin_operator
fill jar_0 water_fountain fountain
2
49 5
0 3
1
0 50 1 0
1000
end_operator
begin_operator
make-coffee bowl_0 water_machine coffeemachine
3
7 0
61 1
0 0
3
0 62 0 1
0 60 1 0
0 59 1 0
50
end_operator
begin_operator
make-coffee cup_0 water_machine coffeemachine
3
14 0
54 1
0 0
3
0 62 0 1
0 51 1 0
0 53 1 0
50
end_operator
begin_operator
make-coffee cup_1 water_machine coffeemachine
3
21 0
56 1
0 0
3
0 62 0 1
0 52 1 0
0 55 1 0
50
end_operator
begin_operator
make-fruit-bowl apple_0 bowl_0 knife_0 countertop
5
8 0
49 6
59 1
61 1
0 1
3
0 57 0 1
0 60 1 0
0 58 1 0
100
end_operator
begin_operator
move coffeemachine countertop
0
1
0 0 0 1
25
end_operator
begin_operator
move coffeemachine dishwasher
0
1
0 0 0 2
25
end_operator
begin_operator
move coffeemachine fountain
0
1
0 0 0 3
200
end_operator
begin_operator
move coffeemachine pantry
0
1
0 0 0 4
875
end_operator
begin_operator
move coffeemachine servingtable
0
1
0 0 0 5
175
end_operator
begin_operator
move coffeemachine shelf
0
1
0 0 0 6
50
end_operator
begin_operator
move countertop coffeemachine
0
1
0 0 1 0
25
end_operator
begin_operator
move countertop dishwasher
0
1
0 0 1 2
50
end_operator
begin_operator
move countertop fountain
0
1
0 0 1 3
225
end_operator
begin_operator
move countertop pantry
0
1
0 0 1 4
875
end_operator
begin_operator
move countertop servingtable
0
1
0 0 1 5
200
end_operator
begin_operator
move countertop shelf
0
1
0 0 1 6
25
end_operator
begin_operator
move dishwasher coffeemachine
0
1
0 0 2 0
25
end_operator
begin_operator
move dishwasher countertop
0
1
0 0 2 1
50
end_operator
begin_operator
move dishwasher fountain
0
1
0 0 2 3
225
end_operator
begin_operator
move dishwasher pantry
0
1
0 0 2 4
875
end_operator
begin_operator
move dishwasher servingtable
0
1
0 0 2 5
200
end_operator
begin_operator
move dishwasher shelf
0
1
0 0 2 6
75
end_operator
begin_operator
move fountain coffeemachine
0
1
0 0 3 0
200
end_operator
begin_operator
move fountain countertop
0
1
0 0 3 1
225
end_operator
begin_operator
move fountain dishwasher
0
1
0 0 3 2
225
end_operator
begin_operator
move fountain pantry
0
1
0 0 3 4
875
end_operator
begin_operator
move fountain servingtable
0
1
0 0 3 5
50
end_operator
begin_operator
move fountain shelf
0
1
0 0 3 6
200
end_operator
begin_operator
move pantry coffeemachine
0
1
0 0 4 0
875
end_operator
begin_operator
move pantry countertop
0
1
0 0 4 1
875
end_operator
begin_operator
move pantry dishwasher
0
1
0 0 4 2
875
end_operator
begin_operator
move pantry fountain
0
1
0 0 4 3
875
end_operator
begin_operator
move pantry servingtable
0
1
0 0 4 5
875
end_operator
begin_operator
move pantry shelf
0
1
0 0 4 6
875
end_operator
begin_operator
move servingtable coffeemachine
0
1
0 0 5 0
175
end_operator
begin_operator
move servingtable countertop
0
1
0 0 5 1
200
end_operator
begin_operator
move servingtable dishwasher
0
1
0 0 5 2
200
end_operator
begin_operator
move servingtable fountain
0
1
0 0 5 3
50
end_operator
begin_operator
move servingtable pantry
0
1
0 0 5 4
875
end_operator
begin_operator
move servingtable shelf
0
1
0 0 5 6
175
end_operator
begin_operator
move shelf coffeemachine
0
1
0 0 6 0
50
end_operator
begin_operator
move shelf countertop
0
1
0 0 6 1
25
end_operator
begin_operator
move shelf dishwasher
0
1
0 0 6 2
75
end_operator
begin_operator
move shelf fountain
0
1
0 0 6 3
200
end_operator
begin_operator
move shelf pantry
0
1
0 0 6 4
875
end_operator
begin_operator
move shelf servingtable
0
1
0 0 6 5
175
end_operator
begin_operator
pick apple_0 coffeemachine
1
0 0
2
0 1 0 1
0 49 0 1
100
end_operator
begin_operator
pick apple_0 countertop
1
0 1
2
0 57 0 1
0 49 0 1
100
end_operator
begin_operator
pick apple_0 dishwasher
1
0 2
2
0 2 0 1
0 49 0 1
100
end_operator
begin_operator
pick apple_0 fountain
1
0 3
2
0 3 0 1
0 49 0 1
100
end_operator
begin_operator
pick apple_0 pantry
1
0 4
2
0 4 0 1
0 49 0 1
100
end_operator
begin_operator
pick apple_0 servingtable
1
0 5
2
0 5 0 1
0 49 0 1
100
end_operator
begin_operator
pick apple_0 shelf
1
0 6
2
0 6 0 1
0 49 0 1
100
end_operator
begin_operator
pick bowl_0 coffeemachine
1
0 0
2
0 7 0 1
0 49 0 2
100
end_operator
begin_operator
pick bowl_0 countertop
1
0 1
2
0 8 0 1
0 49 0 2
100
end_operator
begin_operator
pick bowl_0 dishwasher
1
0 2
2
0 9 0 1
0 49 0 2
100
end_operator
begin_operator
pick bowl_0 fountain
1
0 3
2
0 10 0 1
0 49 0 2
100
end_operator
begin_operator
pick bowl_0 pantry
1
0 4
2
0 11 0 1
0 49 0 2
100
end_operator
begin_operator
pick bowl_0 servingtable
1
0 5
2
0 12 0 1
0 49 0 2
100
end_operator
begin_operator
pick bowl_0 shelf
1
0 6
2
0 13 0 1
0 49 0 2
100
end_operator
begin_operator
pick cup_0 coffeemachine
1
0 0
2
0 14 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_0 countertop
1
0 1
2
0 15 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_0 dishwasher
1
0 2
2
0 16 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_0 fountain
1
0 3
2
0 17 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_0 pantry
1
0 4
2
0 18 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_0 servingtable
1
0 5
2
0 19 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_0 shelf
1
0 6
2
0 20 0 1
0 49 0 3
100
end_operator
begin_operator
pick cup_1 coffeemachine
1
0 0
2
0 21 0 1
0 49 0 4
100
end_operator
begin_operator
pick cup_1 countertop
1
0 1
2
0 22 0 1
0 49 0 4
100
end_operator
begin_operator
pick cup_1 dishwasher
1
0 2
2
0 23 0 1
0 49 0 4
100
end_operator
begin_operator
pick cup_1 fountain
1
0 3
2
0 24 0 1
0 49 0 4
100
end_operator
begin_operator
pick cup_1 pantry
1
0 4
2
0 25 0 1
0 49 0 4
100
end_operator
begin_operator
pick cup_1 servingtable
1
0 5
2
0 26 0 1
0 49 0 4
100
end_operator
begin_operator
pick cup_1 shelf
1
0 6
2
0 27 0 1
0 49 0 4
100
end_operator
begin_operator
pick jar_0 coffeemachine
1
0 0
2
0 28 0 1
0 49 0 5
100
end_operator
begin_operator
pick jar_0 countertop
1
0 1
2
0 29 0 1
0 49 0 5
100
end_operator
begin_operator
pick jar_0 dishwasher
1
0 2
2
0 30 0 1
0 49 0 5
100
end_operator
begin_operator
pick jar_0 fountain
1
0 3
2
0 31 0 1
0 49 0 5
100
end_operator
begin_operator
pick jar_0 pantry
1
0 4
2
0 32 0 1
0 49 0 5
100
end_operator
begin_operator
pick jar_0 servingtable
1
0 5
2
0 33 0 1
0 49 0 5
100
end_operator
begin_operator
pick jar_0 shelf
1
0 6
2
0 34 0 1
0 49 0 5
100
end_operator
begin_operator
pick knife_0 coffeemachine
1
0 0
2
0 35 0 1
0 49 0 6
100
end_operator
begin_operator
pick knife_0 countertop
1
0 1
2
0 36 0 1
0 49 0 6
100
end_operator
begin_operator
pick knife_0 dishwasher
1
0 2
2
0 37 0 1
0 49 0 6
100
end_operator
begin_operator
pick knife_0 fountain
1
0 3
2
0 38 0 1
0 49 0 6
100
end_operator
begin_operator
pick knife_0 pantry
1
0 4
2
0 39 0 1
0 49 0 6
100
end_operator
begin_operator
pick knife_0 servingtable
1
0 5
2
0 40 0 1
0 49 0 6
100
end_operator
begin_operator
pick knife_0 shelf
1
0 6
2
0 41 0 1
0 49 0 6
100
end_operator
begin_operator
pick plate_0 coffeemachine
1
0 0
2
0 42 0 1
0 49 0 7
100
end_operator
begin_operator
pick plate_0 countertop
1
0 1
2
0 43 0 1
0 49 0 7
100
end_operator
begin_operator
pick plate_0 dishwasher
1
0 2
2
0 44 0 1
0 49 0 7
100
end_operator
begin_operator
pick plate_0 fountain
1
0 3
2
0 45 0 1
0 49 0 7
100
end_operator
begin_operator
pick plate_0 pantry
1
0 4
2
0 46 0 1
0 49 0 7
100
end_operator
begin_operator
pick plate_0 servingtable
1
0 5
2
0 47 0 1
0 49 0 7
100
end_operator
begin_operator
pick plate_0 shelf
1
0 6
2
0 48 0 1
0 49 0 7
100
end_operator
begin_operator
place apple_0 coffeemachine
1
0 0
2
0 1 -1 0
0 49 1 0
100
end_operator
begin_operator
place apple_0 countertop
1
0 1
2
0 57 -1 0
0 49 1 0
100
end_operator
begin_operator
place apple_0 dishwasher
1
0 2
2
0 2 -1 0
0 49 1 0
100
end_operator
begin_operator
place apple_0 fountain
1
0 3
2
0 3 -1 0
0 49 1 0
100
end_operator
begin_operator
place apple_0 pantry
1
0 4
2
0 4 -1 0
0 49 1 0
100
end_operator
begin_operator
place apple_0 servingtable
1
0 5
2
0 5 -1 0
0 49 1 0
100
end_operator
begin_operator
place apple_0 shelf
1
0 6
2
0 6 -1 0
0 49 1 0
100
end_operator
begin_operator
place bowl_0 coffeemachine
1
0 0
2
0 7 -1 0
0 49 2 0
100
end_operator
begin_operator
place bowl_0 countertop
1
0 1
2
0 8 -1 0
0 49 2 0
100
end_operator
begin_operator
place bowl_0 dishwasher
1
0 2
2
0 9 -1 0
0 49 2 0
100
end_operator
begin_operator
place bowl_0 fountain
1
0 3
2
0 10 -1 0
0 49 2 0
100
end_operator
begin_operator
place bowl_0 pantry
1
0 4
2
0 11 -1 0
0 49 2 0
100
end_operator
begin_operator
place bowl_0 servingtable
1
0 5
2
0 12 -1 0
0 49 2 0
100
end_operator
begin_operator
place bowl_0 shelf
1
0 6
2
0 13 -1 0
0 49 2 0
100
end_operator
begin_operator
place cup_0 coffeemachine
1
0 0
2
0 14 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_0 countertop
1
0 1
2
0 15 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_0 dishwasher
1
0 2
2
0 16 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_0 fountain
1
0 3
2
0 17 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_0 pantry
1
0 4
2
0 18 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_0 servingtable
1
0 5
2
0 19 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_0 shelf
1
0 6
2
0 20 -1 0
0 49 3 0
100
end_operator
begin_operator
place cup_1 coffeemachine
1
0 0
2
0 21 -1 0
0 49 4 0
100
end_operator
begin_operator
place cup_1 countertop
1
0 1
2
0 22 -1 0
0 49 4 0
100
end_operator
begin_operator
place cup_1 dishwasher
1
0 2
2
0 23 -1 0
0 49 4 0
100
end_operator
begin_operator
place cup_1 fountain
1
0 3
2
0 24 -1 0
0 49 4 0
100
end_operator
begin_operator
place cup_1 pantry
1
0 4
2
0 25 -1 0
0 49 4 0
100
end_operator
begin_operator
place cup_1 servingtable
1
0 5
2
0 26 -1 0
0 49 4 0
100
end_operator
begin_operator
place cup_1 shelf
1
0 6
2
0 27 -1 0
0 49 4 0
100
end_operator
begin_operator
place jar_0 coffeemachine
1
0 0
2
0 28 -1 0
0 49 5 0
100
end_operator
begin_operator
place jar_0 countertop
1
0 1
2
0 29 -1 0
0 49 5 0
100
end_operator
begin_operator
place jar_0 dishwasher
1
0 2
2
0 30 -1 0
0 49 5 0
100
end_operator
begin_operator
place jar_0 fountain
1
0 3
2
0 31 -1 0
0 49 5 0
100
end_operator
begin_operator
place jar_0 pantry
1
0 4
2
0 32 -1 0
0 49 5 0
100
end_operator
begin_operator
place jar_0 servingtable
1
0 5
2
0 33 -1 0
0 49 5 0
100
end_operator
begin_operator
place jar_0 shelf
1
0 6
2
0 34 -1 0
0 49 5 0
100
end_operator
begin_operator
place knife_0 coffeemachine
1
0 0
2
0 35 -1 0
0 49 6 0
100
end_operator
begin_operator
place knife_0 countertop
1
0 1
2
0 36 -1 0
0 49 6 0
100
end_operator
begin_operator
place knife_0 dishwasher
1
0 2
2
0 37 -1 0
0 49 6 0
100
end_operator
begin_operator
place knife_0 fountain
1
0 3
2
0 38 -1 0
0 49 6 0
100
end_operator
begin_operator
place knife_0 pantry
1
0 4
2
0 39 -1 0
0 49 6 0
100
end_operator
begin_operator
place knife_0 servingtable
1
0 5
2
0 40 -1 0
0 49 6 0
100
end_operator
begin_operator
place knife_0 shelf
1
0 6
2
0 41 -1 0
0 49 6 0
100
end_operator
begin_operator
place plate_0 coffeemachine
1
0 0
2
0 42 -1 0
0 49 7 0
100
end_operator
begin_operator
place plate_0 countertop
1
0 1
2
0 43 -1 0
0 49 7 0
100
end_operator
begin_operator
place plate_0 dishwasher
1
0 2
2
0 44 -1 0
0 49 7 0
100
end_operator
begin_operator
place plate_0 fountain
1
0 3
2
0 45 -1 0
0 49 7 0
100
end_operator
begin_operator
place plate_0 pantry
1
0 4
2
0 46 -1 0
0 49 7 0
100
end_operator
begin_operator
place plate_0 servingtable
1
0 5
2
0 47 -1 0
0 49 7 0
100
end_operator
begin_operator
place plate_0 shelf
1
0 6
2
0 48 -1 0
0 49 7 0
100
end_operator
begin_operator
pour bowl_0 water_machine coffeemachine
2
49 2
0 0
3
0 62 -1 0
0 59 -1 1
0 61 0 1
200
end_operator
begin_operator
pour bowl_0 water_machine coffeemachine
2
49 2
0 0
3
1 61 0 62 -1 0
0 59 0 1
0 61 -1 1
200
end_operator
begin_operator
pour cup_0 water_machine coffeemachine
2
49 3
0 0
3
0 62 -1 0
0 53 -1 1
0 54 0 1
200
end_operator
begin_operator
pour cup_0 water_machine coffeemachine
2
49 3
0 0
3
1 54 0 62 -1 0
0 53 0 1
0 54 -1 1
200
end_operator
begin_operator
pour cup_1 water_machine coffeemachine
2
49 4
0 0
3
0 62 -1 0
0 55 -1 1
0 56 0 1
200
end_operator
begin_operator
pour cup_1 water_machine coffeemachine
2
49 4
0 0
3
1 56 0 62 -1 0
0 55 0 1
0 56 -1 1
200
end_operator
begin_operator
pour jar_0 water_machine coffeemachine
2
49 5
0 0
2
0 62 -1 0
0 50 0 1
200
end_operator
begin_operator
refill-water bowl_0 jar_0 coffeemachine
6
28 0
60 1
49 2
59 1
50 0
0 0
1
0 61 1 0
50
end_operator
begin_operator
refill-water bowl_0 jar_0 countertop
6
29 0
60 1
49 2
59 1
50 0
0 1
1
0 61 1 0
50
end_operator
begin_operator
refill-water bowl_0 jar_0 dishwasher
6
30 0
60 1
49 2
59 1
50 0
0 2
1
0 61 1 0
50
end_operator
begin_operator
refill-water bowl_0 jar_0 fountain
6
31 0
60 1
49 2
59 1
50 0
0 3
1
0 61 1 0
50
end_operator
begin_operator
refill-water bowl_0 jar_0 pantry
6
32 0
60 1
49 2
59 1
50 0
0 4
1
0 61 1 0
50
end_operator
begin_operator
refill-water bowl_0 jar_0 servingtable
6
33 0
60 1
49 2
59 1
50 0
0 5
1
0 61 1 0
50
end_operator
begin_operator
refill-water bowl_0 jar_0 shelf
6
34 0
60 1
49 2
59 1
50 0
0 6
1
0 61 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 coffeemachine
6
28 0
51 1
49 3
53 1
50 0
0 0
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 countertop
6
29 0
51 1
49 3
53 1
50 0
0 1
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 dishwasher
6
30 0
51 1
49 3
53 1
50 0
0 2
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 fountain
6
31 0
51 1
49 3
53 1
50 0
0 3
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 pantry
6
32 0
51 1
49 3
53 1
50 0
0 4
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 servingtable
6
33 0
51 1
49 3
53 1
50 0
0 5
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_0 jar_0 shelf
6
34 0
51 1
49 3
53 1
50 0
0 6
1
0 54 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 coffeemachine
6
28 0
52 1
49 4
55 1
50 0
0 0
1
0 56 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 countertop
6
29 0
52 1
49 4
55 1
50 0
0 1
1
0 56 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 dishwasher
6
30 0
52 1
49 4
55 1
50 0
0 2
1
0 56 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 fountain
6
31 0
52 1
49 4
55 1
50 0
0 3
1
0 56 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 pantry
6
32 0
52 1
49 4
55 1
50 0
0 4
1
0 56 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 servingtable
6
33 0
52 1
49 4
55 1
50 0
0 5
1
0 56 1 0
50
end_operator
begin_operator
refill-water cup_1 jar_0 shelf
6
34 0
52 1
49 4
55 1
50 0
0 6
1
0 56 1 0
50
end_operator
begin_operator
wash bowl_0 dishwasher
2
9 0
0 2
3
0 60 0 1
0 59 -1 1
0 61 -1 1
200
end_operator
begin_operator
wash cup_0 dishwasher
2
16 0
0 2
3
0 51 0 1
0 53 -1 1
0 54 -1 1
200
end_operator
begin_operator
wash cup_1 dishwasher
2
23 0
0 2
3
0 52 0 1
0 55 -1 1
0 56 -1 1
200
end_operator
begin_operator
wash knife_0 dishwasher
2
37 0
0 2
1
0 58 0 1
200
end_operator
2
begin_rule
2
19 0
53 0
63 1 0
end_rule
begin_rule
2
26 0
55 0
63 1 0
end_rule
